"""The real racer folders in ../shared/fixtures/real assemble into what their README states."""

from __future__ import annotations

from pathlib import Path

import pytest
from drboard_assembler import AssemblyError, Overrides, Record, assemble
from drboard_assembler.record import RaceType, SourceLayout

pytestmark = pytest.mark.fixtures


@pytest.fixture
def console_run(fixtures_dir: Path) -> Path:
    return fixtures_dir / "real" / "console-2020-rightangle"


@pytest.fixture
def drfc_run(fixtures_dir: Path) -> Path:
    return fixtures_dir / "real" / "drfc-2022-sample"


def test_console_folder_uses_the_evaluation_whose_metrics_are_present(console_run: Path) -> None:
    record = assemble(console_run)

    assert record.racer == "Orthogonal"
    assert record.model_name == "rightangle"
    # Two eval_params files: Belille (metrics present) and an Aragon league submission (absent).
    assert record.track == "Belille"
    assert record.race_type == RaceType.OBJECT_AVOIDANCE
    assert record.source_layout == SourceLayout.CONSOLE
    assert record.direction is None

    assert len(record.evaluations) == 1
    run = record.evaluations[0]
    assert run.source == "metrics/evaluation/evaluation-20201025154221-dbyt0pzUQsWS5PpBqQwpEA.json"
    assert [lap.status for lap in run.laps] == ["Crashed"] * 3
    assert [lap.completion_pct for lap in run.laps] == [3, 3, 3]
    assert [lap.crashes for lap in run.laps] == [1, 1, 1]
    assert run.laps_completed == 0
    assert run.best_lap_ms is None
    assert run.best_completion_pct == 3

    design = record.design
    assert design.metadata_version == "3"
    assert design.algorithm == "clipped_ppo"
    assert design.action_space.type == "discrete"
    assert design.action_space.actions is not None and len(design.action_space.actions) == 6
    assert design.action_space.max_speed == 1.0
    assert set(design.sensors) == {"STEREO_CAMERAS", "SECTOR_LIDAR"}
    assert design.hyperparameters.loss_type == "huber"

    assert record.training is not None
    assert record.training.track == "Aragon"
    assert 0 < record.training.episodes <= 245
    assert len(record.training.curve) <= 200

    roles = {source.path: source.role for source in record.provenance}
    # only the Belille evaluation's parameters describe the run; the league race's name a
    # metrics file the folder does not hold
    assert [path for path, role in roles.items() if role == "evaluation_params"] == [
        "eval_params_ce4c7dca-7fb5-4e3f-814d-0fd06840d94d.yaml"]
    assert list(roles.values()).count("training_params") == 1


def test_console_record_round_trips(console_run: Path) -> None:
    record = assemble(console_run)
    assert Record.model_validate_json(record.model_dump_json()) == record


def test_drfc_folder_without_params_asks_for_every_missing_fact_at_once(drfc_run: Path) -> None:
    with pytest.raises(AssemblyError) as caught:
        assemble(drfc_run)
    assert str(caught.value) == (f"{drfc_run}: WORLD_NAME, RACER_NAME, RACE_TYPE: the run's files "
                                 "do not say (use --track, --racer, --race-type)")


def test_drfc_folder_with_a_track_but_no_racer_asks_for_the_racer(drfc_run: Path) -> None:
    with pytest.raises(AssemblyError) as caught:
        assemble(drfc_run, Overrides(track="reInvent2019"))
    assert "RACER_NAME, RACE_TYPE: " in str(caught.value)
    assert "(use --racer, --race-type)" in str(caught.value)


def test_drfc_folder_with_track_and_racer_from_the_command_line(drfc_run: Path) -> None:
    record = assemble(drfc_run, Overrides(track="reInvent2019", racer="Sample Racer",
                                          race_type="time_trial"))

    assert record.track == "reInvent2019_track"
    assert record.racer == "Sample Racer"
    assert record.model_name == "drfc-2022-sample"
    assert record.source_layout == SourceLayout.DRFC

    assert len(record.evaluations) == 3
    for run in record.evaluations:
        assert [lap.status for lap in run.laps] == ["In progress", "In progress", "Lap complete"]
        assert all(lap.completion_pct == 100 for lap in run.laps)
        assert run.laps_completed == 3
    assert record.best_run.best_lap_ms == 13392

    design = record.design
    assert design.metadata_version == "4"
    assert design.algorithm == "clipped_ppo"
    assert design.action_space.actions is not None and len(design.action_space.actions) == 14
    assert design.sensors == ["FRONT_FACING_CAMERA"]

    assert record.training is not None
    assert record.training.episodes == 541  # 600 entries, 59 of them evaluation phase
    assert record.training.track is None
    assert len(record.training.curve) == 200
    assert Record.model_validate_json(record.model_dump_json()) == record
