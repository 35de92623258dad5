"""Evaluation conditions are part of a run: a board may require them, every board shows them, and
records stored before conditions (and unknown design facts) still read and rank as they did."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from drboard_assembler import assemble
from drboard_assembler.record import Conditions, EvaluationRun, RaceType, Record, content_hash
from drboard_cli.main import cli
from drboard_functions import web
from drboard_functions.errors import BoardLocked, BoardMismatch
from drboard_functions.models.domain import BoardConditions
from drboard_functions.models.requests import BoardChanges, BoardSpec
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record

TRACK = "reInvent2019_track"
EXAMPLES = Path(__file__).parents[2] / "examples"
STORED_V1 = Path(__file__).parents[1] / "data" / "record-v1-speedy.json"
NOW = datetime(2026, 12, 1, 18, 0, tzinfo=UTC)


def evaluated(racer: str, laps: list[tuple[int, float]] | None = None, *,
              runs: list[tuple[list[tuple[int, float]], dict[str, Any] | None]] | None = None) -> Record:
    """A record whose evaluation runs state these conditions (None: none stated)."""
    runs = runs or [(laps or [(12000, 100)], {"off_track_penalty_s": 5.0, "trials": 3})]
    base = make_record(racer, runs=[spec for spec, _ in runs])
    evaluations = [run.model_copy(update={"conditions": Conditions(**stated) if stated else None})
                   for run, (_, stated) in zip(base.evaluations, runs, strict=True)]
    fields = base.model_dump(exclude={"submission_id", "evaluations"})
    return Record.build(**fields, evaluations=[EvaluationRun.model_validate(run.model_dump())
                                               for run in evaluations])


@pytest.fixture
def service() -> LeaderboardService:
    return LeaderboardService(SqliteStore(":memory:"))


@pytest.fixture
def cup(service: LeaderboardService) -> str:
    service.create_board(BoardSpec(board_id="cup", title="Cup", track="reInvent2019",
                                   conditions=BoardConditions(off_track_penalty_s=5, trials=3)))
    return "cup"


def test_a_run_evaluated_under_the_required_conditions_ranks(service: LeaderboardService, cup: str) -> None:
    receipt = service.push(evaluated("Ada"), cup)
    assert receipt.entry.qualified
    assert receipt.entry.conditions == Conditions(off_track_penalty_s=5.0, trials=3)
    assert service.board_page(cup).board.conditions == BoardConditions(off_track_penalty_s=5, trials=3)


@pytest.mark.parametrize(("stated", "problem"), [
    ({"off_track_penalty_s": 2.0, "trials": 3},
     "off-track penalty 2 s (the board requires 5 s)"),
    ({"off_track_penalty_s": 5.0, "trials": 1}, "trials 1 (the board requires 3)"),
    (None, "off-track penalty not stated by its evaluation parameters (the board requires 5 s), "
           "trials not stated by its evaluation parameters (the board requires 3)"),
])
def test_a_run_evaluated_under_other_conditions_is_refused_naming_the_difference(
        service: LeaderboardService, cup: str, stated: dict[str, Any] | None, problem: str) -> None:
    with pytest.raises(BoardMismatch) as refused:
        service.push(evaluated("Ada", runs=[([(12000, 100)], stated)]), cup)
    assert str(refused.value) == ("this run does not belong on 'cup': its evaluation ran under other "
                                  f"conditions: {problem}")
    assert service.board_page(cup).entries == []


def test_only_the_runs_under_the_required_conditions_score(service: LeaderboardService, cup: str) -> None:
    record = evaluated("Ada", runs=[([(9000, 100)], {"off_track_penalty_s": 0.0, "trials": 3}),
                                    ([(12000, 100)], {"off_track_penalty_s": 5.0, "trials": 3})])
    receipt = service.push(record, cup)
    assert receipt.entry.time_ms == 12000  # not the faster run evaluated without a penalty
    on_default = service.push(record)
    assert on_default.entry.time_ms == 9000  # the default board takes any conditions


def test_the_required_conditions_are_locked_once_the_board_has_entries(
        service: LeaderboardService, cup: str) -> None:
    service.update_board(cup, BoardChanges(conditions=BoardConditions(trials=5)))
    assert service.board_page(cup).board.conditions == BoardConditions(trials=5)
    service.update_board(cup, BoardChanges.model_validate({"conditions": None}))
    assert service.board_page(cup).board.conditions is None
    service.push(evaluated("Ada"), cup)
    with pytest.raises(BoardLocked):
        service.update_board(cup, BoardChanges(conditions=BoardConditions(trials=3)))


def test_the_cli_creates_a_board_requiring_conditions_and_refuses_a_run_with_exit_2(tmp_path: Path) -> None:
    db = str(tmp_path / "board.sqlite")
    runner = CliRunner()
    made = runner.invoke(cli, ["--db", db, "board", "create", "pen5", "--title", "Five", "--track",
                               "reInvent2019", "--require", "off-track-penalty=5s", "--require", "trials=3"])
    assert made.exit_code == 0, made.output
    assert "off-track penalty 5 s · trials 3" in made.output
    pushed = runner.invoke(cli, ["--db", db, "push", str(EXAMPLES / "speedy-ppo-console"), "--board", "pen5"])
    assert pushed.exit_code == 2
    assert ("its evaluation ran under other conditions: off-track penalty 2 s (the board requires "
            "5 s)") in pushed.output
    bad = runner.invoke(cli, ["--db", db, "board", "update", "pen5", "--require", "speed=3"])
    assert bad.exit_code == 2 and "the conditions are off-track-penalty" in bad.output
    cleared = runner.invoke(cli, ["--db", db, "board", "update", "pen5", "--require", "none"])
    assert cleared.exit_code == 0 and "any (each entry shows its own)" in cleared.output


# ------------------------------------------------------------------ shown on every board

def test_a_default_board_shows_each_entrys_conditions(service: LeaderboardService, tmp_path: Path) -> None:
    service.push(evaluated("Ada"))
    service.push(evaluated("Bob", runs=[([(11000, 100)], {"off_track_penalty_s": 2.0, "continuous": True})]))
    page = service.board_page(TRACK)
    assert [entry.conditions for entry in page.entries] == [
        Conditions(off_track_penalty_s=2.0, continuous=True), Conditions(off_track_penalty_s=5.0, trials=3)]
    html = web.board_page(page, now=NOW)
    assert "off-track 2 s, continuous" in html and "off-track 5 s, 3 trials" in html
    assert "times include penalties" in html


def test_the_cli_table_and_csv_show_each_entrys_conditions(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "160")  # a wide terminal: the table has room for them
    db = str(tmp_path / "board.sqlite")
    runner = CliRunner()
    assert runner.invoke(cli, ["--db", db, "push", str(EXAMPLES / "speedy-ppo-console")]).exit_code == 0
    table = runner.invoke(cli, ["--db", db, "pull", "--track", "reInvent2019"])
    assert "off-track 2 s, 3 trials" in table.output
    csv_text = runner.invoke(cli, ["--db", db, "pull", "--track", "reInvent2019", "--format", "csv"]).output
    assert csv_text.splitlines()[0].endswith(",conditions")
    assert csv_text.splitlines()[1].endswith(',"off-track 2 s, 3 trials"')


def test_the_racer_page_and_show_say_the_conditions_and_that_times_hold_penalties(
        service: LeaderboardService, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "160")
    service.push(assemble(EXAMPLES / "speedy-ppo-console"))
    html = web.racer_page(service.racer(TRACK, "Speedy"))
    assert "Evaluation conditions" in html and "Lap times include the penalties" in html
    assert "<th scope=\"row\">off-track penalty</th><td>2 s</td>" in html
    assert "<th scope=\"row\">collision penalty</th><td>unknown</td>" in html
    db = str(tmp_path / "board.sqlite")
    runner = CliRunner()
    assert runner.invoke(cli, ["--db", db, "push", str(EXAMPLES / "speedy-ppo-console")]).exit_code == 0
    shown = runner.invoke(cli, ["--db", db, "show", "Speedy", "--track", "reInvent2019"])
    assert "off-track penalty 2 s · trials 3" in shown.output
    assert "Lap times include the penalties" in shown.output


# ------------------------------------------------------------------ unknown design facts

def unknown_design(racer: str) -> Record:
    fields = make_record(racer).model_dump(exclude={"submission_id"})
    fields["design"] = {}
    return Record.build(**fields)


def test_an_unknown_design_reads_as_unknown_on_the_pages_and_in_show(
        service: LeaderboardService, tmp_path: Path) -> None:
    service.push(unknown_design("Ada"))
    service.push(make_record("Bob", laps=[(13000, 100)]))
    page = service.board_page(TRACK)
    assert "design unknown" in web.board_page(page, now=NOW)
    racer_html = web.racer_page(service.racer(TRACK, "Ada"))
    assert "<p>Unknown: the run's files do not describe the model's action space.</p>" in racer_html
    assert "<th scope=\"row\">top speed (m/s)</th><td>unknown</td>" in racer_html
    comparison = service.compare(TRACK, ["Ada", "Bob"])
    compare_html = web.compare_page(comparison)
    assert "unknown" in compare_html
    ada = next(c for c in comparison.racers if c.racer == "Ada")
    assert {"algorithm", "max_speed", "discount_factor"} <= set(ada.facts.unknown)


def test_insights_leave_unknown_facts_out(service: LeaderboardService) -> None:
    service.push(unknown_design("Ada"))
    service.push(make_record("Bob", laps=[(13000, 100)], max_speed=3.0))
    service.push(make_record("Cy", laps=[(14000, 100)], max_speed=2.0))
    insights = service.insights(TRACK, top=1)
    speed = next(fact for fact in insights.facts if fact.fact == "max_speed")
    # Ada, fastest but of unknown design, counts in neither group's figures
    assert (speed.top, speed.field) == ("3", "2.5")


# ------------------------------------------------------------------ stored records of schema 1

def test_a_record_stored_before_conditions_and_sources_reads_and_keeps_its_id() -> None:
    stored = STORED_V1.read_text()
    record = Record.model_validate_json(stored)
    assert record.submission_id == json.loads(stored)["submission_id"] == content_hash(record)
    assert record.design.sources is None and all(run.conditions is None for run in record.evaluations)
    assert record.design.action_space is not None and record.design.hyperparameters is not None


def test_a_stored_record_ranks_and_shows_as_before(service: LeaderboardService) -> None:
    record = Record.model_validate_json(STORED_V1.read_text())
    receipt = service.push(record)
    assert receipt.entry.qualified and receipt.entry.flags == []
    assert receipt.entry.conditions is None
    html = web.racer_page(service.racer(TRACK, record.racer))
    assert "<th scope=\"row\">off-track penalty</th><td>unknown</td>" in html


# ------------------------------------------------------------------ a track's other boards

def test_pull_of_a_track_with_only_its_object_avoidance_board_lists_its_boards(tmp_path: Path) -> None:
    db = str(tmp_path / "board.sqlite")
    LeaderboardService(SqliteStore(db)).push(make_record("Orthogonal", track="Belille",
                                                         race_type=RaceType.OBJECT_AVOIDANCE))
    runner = CliRunner()
    pulled = runner.invoke(cli, ["--db", db, "pull", "--track", "Belille"])
    assert pulled.exit_code == 1
    assert pulled.output == ("error: no board 'Belille': no run was pushed to the track's default board; "
                             "its boards are Belille_oa (Cumulo Turnpike, object avoidance, 1 racer) "
                             "(use --board ID)\n")
    nowhere = runner.invoke(cli, ["--db", db, "pull", "--track", "Aragon"])
    assert nowhere.exit_code == 1 and "its boards are" not in nowhere.output
