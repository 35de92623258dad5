"""Every example run assembles, with no flags, into the record a racer expects to see."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import tarfile
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest
from drboard_assembler import AssemblyError, Overrides, Record, assemble, evaluation_files, planned_trials
from drboard_assembler.record import RaceType, SourceLayout

EXAMPLES = Path(__file__).parents[2] / "examples"
TRACK = "reInvent2019_track"
TARGET_RECORD_BYTES = 16 * 1024


@dataclass(frozen=True)
class Expected:
    racer: str
    layout: SourceLayout
    direction: str | None
    algorithm: str
    action_space: str
    max_speed: float
    metadata_version: str | None
    runs: int
    laps_completed: int  # in the best run
    best_lap_ms: int | None
    best_completion_pct: float
    training_episodes: int
    training_track: str | None


EXPECTED = {
    "speedy-ppo-console": Expected(
        "Speedy", SourceLayout.CONSOLE, None, "clipped_ppo", "discrete", 3.0, "4",
        1, 3, 10873, 100.0, 200, TRACK),
    "rookie-ppo-console": Expected(
        "Rookie", SourceLayout.CONSOLE, None, "clipped_ppo", "discrete", 1.5, None,
        1, 0, None, 52.0, 120, TRACK),
    "drifter-ppo-drfc": Expected(
        "Drifter", SourceLayout.DRFC, None, "clipped_ppo", "discrete", 3.5, "4",
        3, 3, 9968, 100.0, 240, "reInvent2019_wide"),
    "comet-sac-drfc": Expected(
        "Comet", SourceLayout.DRFC, None, "sac", "continuous", 3.2, "5",
        2, 3, 10788, 100.0, 260, TRACK),
    "indy-sac-droa": Expected(
        "Indy", SourceLayout.DROA, "ccw", "sac", "continuous", 4.0, "6",
        1, 3, 9405, 100.0, 220, None),
    "blaze-ppo-droa": Expected(
        "Blaze", SourceLayout.DROA, "ccw", "clipped_ppo", "discrete", 4.0, "6",
        2, 5, 8655, 100.0, 250, None),
    "lefty-ppo-drfc-cw": Expected(
        "Lefty", SourceLayout.DRFC, "cw", "clipped_ppo", "discrete", 2.8, "5",
        1, 3, 11512, 100.0, 160, "reInvent2019_track"),
}


@cache
def record_of(name: str) -> Record:
    return assemble(EXAMPLES / name)


def test_every_example_folder_has_expectations() -> None:
    folders = {p.name for p in EXAMPLES.iterdir() if p.is_dir()}
    assert folders == set(EXPECTED)
    assert len([e for e in EXPECTED.values() if e.direction != "cw"]) >= 6


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_example_assembles_to_what_the_racer_sees(name: str) -> None:
    expected = EXPECTED[name]
    record = record_of(name)

    assert record.track == TRACK
    assert not record.custom_track
    assert record.direction == expected.direction
    assert record.racer == expected.racer
    assert record.model_name == name
    assert record.race_type == RaceType.TIME_TRIAL
    assert record.source_layout == expected.layout

    assert len(record.evaluations) == expected.runs
    best = record.best_run
    assert best.laps_completed == expected.laps_completed
    assert best.best_lap_ms == expected.best_lap_ms
    assert best.best_completion_pct == expected.best_completion_pct

    design = record.design
    assert design.algorithm == expected.algorithm
    assert design.action_space.type == expected.action_space
    assert design.action_space.max_speed == expected.max_speed
    assert design.metadata_version == expected.metadata_version

    assert record.training is not None
    assert record.training.episodes == expected.training_episodes
    assert record.training.track == expected.training_track
    assert 0 < len(record.training.curve) <= 200
    episodes = [point.episode for point in record.training.curve]
    assert episodes == sorted(episodes)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_lap_times_are_physically_plausible(name: str) -> None:
    record = record_of(name)
    top_speed = record.design.action_space.max_speed
    for run in record.evaluations:
        for time_ms in run.completed_times:
            assert 23.12 / top_speed * 1000 < time_ms < 20_000


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_record_survives_a_json_round_trip(name: str) -> None:
    record = record_of(name)
    assert Record.model_validate_json(record.model_dump_json()) == record


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_record_stays_small(name: str) -> None:
    assert len(record_of(name).model_dump_json().encode()) <= TARGET_RECORD_BYTES


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_submission_id_is_stable_and_follows_the_content(name: str) -> None:
    first = assemble(EXAMPLES / name)
    again = assemble(EXAMPLES / name)
    assert first.submission_id == again.submission_id
    renamed = assemble(EXAMPLES / name, Overrides(racer="Someone Else"))
    assert renamed.racer == "Someone Else"
    assert renamed.submission_id != first.submission_id


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_provenance_lists_each_input_with_its_hash(name: str) -> None:
    record = record_of(name)
    roles = {source.role for source in record.provenance}
    assert {"model_metadata", "hyperparameters", "evaluation_metrics",
            "training_metrics", "evaluation_params"} <= roles
    for source in record.provenance:
        data = (EXAMPLES / name / source.path).read_bytes()
        assert source.sha256 == hashlib.sha256(data).hexdigest()
        assert source.bytes == len(data)


def test_continuous_evaluation_counts_in_progress_laps_at_100_percent() -> None:
    record = record_of("drifter-ppo-drfc")
    for run in record.evaluations:
        assert [lap.status for lap in run.laps] == ["In progress", "In progress", "Lap complete"]
        assert run.laps_completed == 3
    penalised = record.evaluations[1]
    assert penalised.off_track_total == 1
    assert penalised.laps[1].time_ms == 13987
    assert penalised.average_lap_ms == round((10543 + 13987 + 10390) / 3)


def test_model_that_never_finishes_is_described_by_its_completion() -> None:
    run = record_of("rookie-ppo-console").best_run
    assert run.laps_completed == 0
    assert run.best_lap_ms is None and run.average_lap_ms is None
    assert [lap.completion_pct for lap in run.laps] == [38, 52, 27, 44, 31]
    assert run.off_track_total == 5


def test_discrete_action_space_without_index_and_metadata_without_version() -> None:
    design = record_of("rookie-ppo-console").design
    assert design.metadata_version is None
    assert design.action_space.actions is not None
    assert len(design.action_space.actions) == 6
    assert all(action.index is None for action in design.action_space.actions)
    assert design.hyperparameters.loss_type == "mean_squared_error"


def test_sac_models_carry_their_continuous_ranges_and_alpha() -> None:
    indy = record_of("indy-sac-droa").design
    assert indy.action_space.speed is not None and indy.action_space.steering_angle is not None
    assert (indy.action_space.speed.low, indy.action_space.speed.high) == (1.0, 4.0)
    assert indy.action_space.max_steering == 30
    assert indy.action_space.actions is None
    assert indy.hyperparameters.sac_alpha == 0.2
    assert indy.hyperparameters.beta_entropy is None
    assert indy.hyperparameters.loss_type == "mean_squared_error"  # "mean squared error" in file
    comet = record_of("comet-sac-drfc").design
    assert comet.hyperparameters.sac_alpha == 0.3
    assert comet.action_space.max_steering == 25


def test_droa_training_params_file_holding_an_evaluation_is_read_as_evaluation() -> None:
    record = record_of("blaze-ppo-droa")
    roles = {source.path: source.role for source in record.provenance}
    assert roles["training_params.yaml"] == "evaluation_params"
    assert record.best_run is record.evaluations[1]
    assert len(record.evaluations[1].laps) == 5


def test_drfc_racer_comes_from_racer_name_before_display_name() -> None:
    assert record_of("comet-sac-drfc").racer == "Comet"  # DISPLAY_NAME is "Comet Racing"
    assert record_of("drifter-ppo-drfc").racer == "Drifter"  # DISPLAY_NAME only


def test_drfc_training_metrics_of_several_workers_are_summed() -> None:
    training = record_of("comet-sac-drfc").training
    assert training is not None
    assert training.episodes == 130 + 130


def test_droa_file_names_with_colons_as_downloaded_from_s3(tmp_path: Path) -> None:
    run = tmp_path / "indy-sac-droa"
    shutil.copytree(EXAMPLES / "indy-sac-droa", run)
    for path in list((run / "metrics").rglob("*.json")):
        path.rename(path.with_name(re.sub(r"T(\d\d)-(\d\d)-(\d\d)", r"T\1:\2:\3", path.name)))
    params = run / "training_params.yaml"
    params.write_text(params.read_text().replace("T11-05-12.381Z", "T11:05:12.381Z"))
    names = sorted(p.name for p in (run / "metrics").rglob("*.json"))
    assert all(":" in name for name in names)

    record = assemble(run)
    assert record.source_layout == SourceLayout.DROA
    assert record.best_run.best_lap_ms == 9405
    assert record.best_run.source.startswith("metrics/evaluation/2025-06-01T11:05:12.381Z-")


def test_track_override_accepts_the_display_name() -> None:
    record = assemble(EXAMPLES / "speedy-ppo-console", Overrides(track="Smile Speedway"))
    assert record.track == TRACK
    assert record.submission_id == record_of("speedy-ppo-console").submission_id


@pytest.mark.parametrize("name", ["speedy-ppo-console", "drifter-ppo-drfc", "indy-sac-droa"])
def test_tarball_of_an_example_assembles_to_the_same_record(name: str, tmp_path: Path) -> None:
    archive = tmp_path / f"{name}.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(EXAMPLES / name, arcname=name)
    from_archive = assemble(archive)
    from_folder = record_of(name)
    assert from_archive.submission_id == from_folder.submission_id
    assert json.loads(from_archive.model_dump_json()) == json.loads(from_folder.model_dump_json())


# ---- one evaluation at a time (`push --watch`) ----------------------------------------------


def test_evaluation_files_are_listed_relative_to_the_run_folder() -> None:
    assert evaluation_files(EXAMPLES / "drifter-ppo-drfc") == [
        "metrics/EvaluationMetrics-20230518205533.json",
        "metrics/EvaluationMetrics-20230518210841.json",
        "metrics/EvaluationMetrics-20230518212207.json",
    ]
    assert evaluation_files(EXAMPLES / "comet-sac-drfc") == [
        "metrics/evaluation/evaluation-20240315093012.json",
        "metrics/evaluation/evaluation-20240315101544.json",
    ]


@pytest.mark.parametrize("name", ["drifter-ppo-drfc", "comet-sac-drfc", "blaze-ppo-droa"])
def test_one_evaluation_is_the_record_of_the_folder_with_only_that_file(name: str,
                                                                        tmp_path: Path) -> None:
    evaluations = evaluation_files(EXAMPLES / name)
    for number, evaluation in enumerate(evaluations):
        alone = tmp_path / str(number) / name
        shutil.copytree(EXAMPLES / name, alone)
        for other in set(evaluations) - {evaluation}:
            (alone / other).unlink()

        record = assemble(EXAMPLES / name, evaluation=evaluation)

        assert [run.source for run in record.evaluations] == [evaluation]
        assert record == assemble(alone)


def test_each_evaluation_is_a_submission_of_its_own_and_stays_the_same() -> None:
    folder = EXAMPLES / "drifter-ppo-drfc"
    ids = [assemble(folder, evaluation=e).submission_id for e in evaluation_files(folder)]
    assert len(set(ids)) == 3
    assert ids[0] == assemble(folder, evaluation=evaluation_files(folder)[0]).submission_id
    assert record_of("drifter-ppo-drfc").submission_id not in ids


def test_one_evaluation_of_an_archive(tmp_path: Path) -> None:
    archive = tmp_path / "drifter-ppo-drfc.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(EXAMPLES / "drifter-ppo-drfc", arcname="drifter-ppo-drfc")
    evaluation = "metrics/EvaluationMetrics-20230518210841.json"
    assert assemble(archive, evaluation=evaluation) == assemble(EXAMPLES / "drifter-ppo-drfc",
                                                                evaluation=evaluation)


@pytest.mark.parametrize("evaluation", ["metrics/evaluation/missing.json",
                                        "metrics/TrainingMetrics.json",
                                        "evaluation-20240315101544.json"])
def test_an_evaluation_the_folder_does_not_hold_is_named_in_the_error(evaluation: str) -> None:
    with pytest.raises(AssemblyError) as caught:
        assemble(EXAMPLES / "comet-sac-drfc", evaluation=evaluation)
    assert str(caught.value) == (f"{EXAMPLES / 'comet-sac-drfc'}: {evaluation}: no such evaluation "
                                 "metrics file in the run folder")


def test_planned_trials_come_from_the_parameters_naming_the_evaluation() -> None:
    comet = EXAMPLES / "comet-sac-drfc"
    assert planned_trials(comet, "metrics/evaluation/evaluation-20240315101544.json") == 3
    assert planned_trials(comet, "metrics/evaluation/evaluation-20240315093012.json") is None
    speedy = EXAMPLES / "speedy-ppo-console"  # the console quotes every value
    assert planned_trials(speedy, evaluation_files(speedy)[0]) == 3
    blaze = EXAMPLES / "blaze-ppo-droa"  # an evaluation's parameters in training_params.yaml
    assert [planned_trials(blaze, e) for e in evaluation_files(blaze)] == [None, 5]
