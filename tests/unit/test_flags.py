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
    speed = record.design.action_space.max_speed
    flagged = {run.source: run_flags(run, record.track, speed) for run in record.evaluations}
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
    ({"time_ms": 6000, "ended_ms": 7000.0}, None, "faster-than-top-speed"),
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
