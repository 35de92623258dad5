"""The board's consistency checks: flagged runs are shown as such, and a board decides whether
they rank."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from drboard_assembler import AssemblyError, assemble
from drboard_assembler.record import EvaluationRun, Lap, Record
from drboard_functions.flags import Flag, run_flags
from drboard_functions.models.requests import BoardSpec
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record

TRACK = "reInvent2019_track"
EXAMPLES = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())


def with_laps(record: Record, *laps: dict[str, Any], named_by_params: bool | None = None) -> Record:
    """The record with one evaluation of these laps (each a Lap's fields over a clean lap)."""
    clean = {"trial": 1, "time_ms": 9000, "completion_pct": 100.0, "status": "Lap complete",
             "started_ms": 1000.0, "ended_ms": 10_000.0, "immobilized": 0, "reversed": 0}
    built = [Lap(**(clean | {"trial": n} | lap)) for n, lap in enumerate(laps, start=1)]
    run = EvaluationRun.from_laps("metrics/evaluation/eval-1.json", built)
    run = run.model_copy(update={"named_by_params": named_by_params})
    fields = record.model_dump(exclude={"submission_id", "evaluations"})
    return Record.build(**fields, evaluations=[run])


def record_flags(record: Record) -> dict[str, list[Flag]]:
    """Each flagged evaluation run's flags, by its source."""
    flagged = {run.source: run_flags(run, record.track, record.design.max_speed)
               for run in record.evaluations}
    return {source: flags for source, flags in flagged.items() if flags}


@pytest.fixture
def service() -> LeaderboardService:
    return LeaderboardService(SqliteStore(":memory:"))


def test_a_clean_run_has_no_flags() -> None:
    second = {"started_ms": 10_000.0, "ended_ms": 19_000.0}
    assert record_flags(with_laps(make_record("Ada"), {}, second)) == {}


@pytest.mark.parametrize(("lap", "named_by_params", "flag"), [
    ({"ended_ms": 4000.0}, None, "lap-timestamps"),
    ({"resets": 2, "crashes": 1}, None, "reset-count"),
    ({}, False, "params-name-another-file"),
    # the shortest lap of the Smile Speedway (17.96 m) takes 5.99 s at the model's 3 m/s
    ({"time_ms": 5500, "ended_ms": 6500.0}, None, "faster-than-top-speed"),
])
def test_each_check_flags_the_run_and_the_board_shows_it(
        service: LeaderboardService, lap: dict[str, Any], named_by_params: bool | None,
        flag: str) -> None:
    record = with_laps(make_record("Ada"), lap, named_by_params=named_by_params)
    receipt = service.push(record)
    assert receipt.entry.flags == [flag]
    assert service.board_page(TRACK).entries[0].flags == [flag]
    assert service.history("Ada")[0].flags == [flag]
    assert receipt.entry.qualified, "a default board ranks flagged runs"


def test_a_board_whose_flagged_runs_do_not_rank_lists_them_below_the_qualified(
        service: LeaderboardService) -> None:
    service.create_board(BoardSpec(board_id="cup", title="Cup", track="reInvent2019",
                                   flagged_runs="unranked"))
    flagged = with_laps(make_record("Ada"), {"time_ms": 8000, "ended_ms": 2000.0})
    clean = with_laps(make_record("Bob"), {"time_ms": 9500, "started_ms": 0.0, "ended_ms": 9500.0})
    service.push(flagged, "cup")
    service.push(clean, "cup")
    entries = service.board_page("cup").entries
    assert [(e.racer, e.qualified, e.flags) for e in entries] == [
        ("Bob", True, []), ("Ada", False, ["lap-timestamps"])]
    assert service.board_page("cup").board.flagged_runs == "unranked"


def test_records_without_timestamps_or_reset_causes_are_not_flagged() -> None:
    assert record_flags(make_record("Ada")) == {}


@pytest.mark.parametrize("run", EXAMPLES, ids=lambda p: p.name)
def test_the_bundled_example_runs_are_not_flagged(run: Path) -> None:
    record = assemble(run)
    assert record_flags(record) == {}
    assert any(lap.started_ms is not None for lap in record.evaluations[0].laps), "timestamps read"


@pytest.mark.fixtures
def test_the_real_racer_runs_with_their_parameters_are_not_flagged(fixtures_dir: Path) -> None:
    checked = 0
    for folder in sorted(p for p in (fixtures_dir / "real").iterdir() if p.is_dir()):
        try:
            record = assemble(folder)
        except AssemblyError:  # a folder that needs --track or --racer: the assembler tests' business
            continue
        assert record_flags(record) == {}, folder.name
        checked += 1
    assert checked >= 1


def test_parameters_naming_a_metrics_file_the_folder_lacks_flag_its_runs(tmp_path: Path) -> None:
    import shutil

    run = tmp_path / "blaze"
    shutil.copytree(Path(__file__).parents[2] / "examples" / "blaze-ppo-droa", run)
    params = run / "training_params.yaml"
    text = params.read_text()
    params.write_text(text.replace("bbnoUuwuIo4bkAE.json", "SomeoneElsesRun.json"))
    flagged = record_flags(assemble(run))
    assert flagged and all(flags == ["params-name-another-file"] for flags in flagged.values())


def test_a_lap_cutting_corners_at_the_top_speed_is_not_flagged() -> None:
    """Faster than the centre line allows (6.2 s at 3 m/s on the Smile Speedway), as a real car
    cutting corners is, but not faster than the track's shortest path: no flag."""
    record = with_laps(make_record("Ada"), {"time_ms": 6200, "ended_ms": 7200.0})
    assert record_flags(record) == {}


def test_the_drfc_fastcar_lap_of_38_043_s_is_not_flagged_and_a_lap_under_the_floor_is(
        tmp_path: Path) -> None:
    from tests.downloadkit import drfc_folder

    genuine = assemble(drfc_folder(tmp_path / "genuine", 38043))
    assert record_flags(genuine) == {}
    too_fast = assemble(drfc_folder(tmp_path / "too-fast", 32000))  # Spain's floor: 32.8 s at 1.5 m/s
    assert list(record_flags(too_fast).values()) == [["faster-than-top-speed"]]


def test_laps_read_from_a_log_carry_their_resets_and_are_not_flagged(tmp_path: Path) -> None:
    """A head-to-bot race read from its log: the off-tracks and crashes it shows are its resets."""
    from tests import layoutkit as kit
    from tests.downloadkit import droa_params

    evaluation = kit.Evaluation((kit.LapSpec(29.0, off_tracks=1, crashes=1), kit.LapSpec(28.5, crashes=2)))
    kit.write(tmp_path / "h2b" / "logs" / "evaluation" / "race-simulation.log",
              kit.evaluation_log(droa_params(RACE_TYPE="HEAD_TO_BOT", NUMBER_OF_BOT_CARS=3), evaluation,
                                 prefix=kit.DROA_PREFIX))
    record = assemble(tmp_path / "h2b")
    assert [(lap.off_track, lap.crashes, lap.resets) for lap in record.evaluations[0].laps] == [
        (1, 1, 2), (0, 2, 2)]
    assert record_flags(record) == {}


def test_a_record_without_an_action_space_is_flagged_design_unknown(service: LeaderboardService) -> None:
    fields = make_record("Ada").model_dump(exclude={"submission_id"})
    fields["design"] = {"algorithm": None, "action_space": None, "sensors": None,
                        "hyperparameters": None}
    record = Record.build(**fields)
    receipt = service.push(record)
    assert receipt.entry.flags == ["design-unknown"]
    assert receipt.entry.qualified, "a default board ranks it"
    assert receipt.entry.design is not None and not receipt.entry.design.known


def test_a_board_whose_flagged_runs_do_not_rank_keeps_an_unknown_design_unranked(
        service: LeaderboardService) -> None:
    service.create_board(BoardSpec(board_id="cup", title="Cup", track="reInvent2019",
                                   flagged_runs="unranked"))
    fields = make_record("Ada").model_dump(exclude={"submission_id"})
    fields["design"] = {}
    receipt = service.push(Record.build(**fields), "cup")
    assert (receipt.entry.qualified, receipt.entry.flags) == (False, ["design-unknown"])
