"""Real racers' downloads: logs as an input, every missing fact named at once, one run per push."""

from __future__ import annotations

import json
import shutil
import tarfile
from pathlib import Path

import pytest
from click.testing import CliRunner
from drboard_assembler import AssemblyError, Overrides, assemble
from drboard_assembler.record import RaceType
from drboard_cli.main import cli

from tests import logkit

EXAMPLES = Path(__file__).parents[2] / "examples"
CONSOLE = "speedy-ppo-console"
EVALUATION = "metrics/evaluation/evaluation-20210412113020-cEQMKFcxiXMeyUPoyZbNEb.json"


def message_of(path: Path, overrides: Overrides | None = None) -> str:
    with pytest.raises(AssemblyError) as caught:
        assemble(path, overrides)
    return str(caught.value)


def pack(folder: Path, archive: Path) -> Path:
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(folder, arcname=folder.name)
    return archive


# ------------------------------------------------------------------ logs are an input

def test_a_log_only_console_download_assembles_with_no_flag(tmp_path: Path) -> None:
    run = logkit.console_log_download(tmp_path / "pitstop-logs")
    record = assemble(run)
    assert (record.track, record.racer, record.model_name, record.race_type) == (
        "reInvent2019_track", "Pitstop", "pitstop-v3", RaceType.TIME_TRIAL)
    [evaluation] = record.evaluations
    assert [lap.status for lap in evaluation.laps] == ["Lap complete", "Off track", "Lap complete"]
    assert [round(lap.time_ms / 100) for lap in evaluation.laps] == [164, 90, 158]
    assert evaluation.best_lap_ms == evaluation.laps[2].time_ms
    assert evaluation.laps[1].completion_pct == pytest.approx(47.3)
    assert evaluation.laps[1].off_track >= 1


def test_a_record_built_from_logs_says_so_in_its_provenance(tmp_path: Path) -> None:
    record = assemble(logkit.console_log_download(tmp_path / "pitstop-logs"))
    roles = {source.path.rsplit("-", 1)[-1]: source.role for source in record.provenance}
    assert roles == {"robomaker.log": "simulation_log", "sagemaker.log": "training_log"}
    assert record.evaluations[0].source.endswith("-robomaker.log")


def test_the_design_comes_from_what_the_job_printed(tmp_path: Path) -> None:
    record = assemble(logkit.console_log_download(tmp_path / "pitstop-logs"))
    assert record.design.algorithm == "clipped_ppo"
    assert record.design.action_space.type == "discrete"
    assert record.design.action_space.max_speed == 3.0
    assert record.design.sensors == ["FRONT_FACING_CAMERA"]
    assert record.design.hyperparameters.batch_size == 64
    assert record.design.hyperparameters.lr == pytest.approx(0.0003)


def test_deepracer_on_aws_prefixed_lines_are_read(tmp_path: Path) -> None:
    run = tmp_path / "droa"
    logkit.write(run / "logs" / "evaluation" /
                 "2026-03-07T17:59:20.610Z-deepracerindy-evaluation-9oJ3Qb-simulation.log",
                 logkit.simulation_log(logkit.job_params(world="Spain_track", racer="Duckling"),
                                       [(28.3, "lap_complete")], prefix=logkit.DROA_PREFIX))
    record = assemble(run)
    assert (record.track, record.racer) == ("Spain_track", "Duckling")
    assert [round(lap.time_ms / 100) for lap in record.evaluations[0].laps] == [283]


def test_an_object_avoidance_run_lands_on_the_object_avoidance_board(tmp_path: Path) -> None:
    run = logkit.console_log_download(tmp_path / "oa", race_type="OBJECT_AVOIDANCE")
    assert assemble(run).race_type == RaceType.OBJECT_AVOIDANCE


def test_the_params_a_log_printed_name_the_run_of_a_metrics_file(tmp_path: Path) -> None:
    """A folder with metrics but no params YAML: the evaluation log gives track, racer, model."""
    run = tmp_path / "download"
    shutil.copytree(EXAMPLES / CONSOLE, run)
    for params in run.glob("*.yaml"):
        params.unlink()
    logkit.write(run / "logs" / "evaluation" / "evaluation-20210412113020-robomaker.log",
                 logkit.simulation_log(logkit.job_params(
                     racer="Logged", model="from-the-log", metrics_key=f"x/{EVALUATION}")))
    record = assemble(run)
    assert (record.racer, record.model_name) == ("Logged", "from-the-log")
    assert record.evaluations[0].source == EVALUATION
    assert record.evaluations[0].named_by_params is True


def test_a_leaderboard_race_logged_without_its_metrics_file_is_one_more_run(tmp_path: Path) -> None:
    """A console download keeps leaderboard races' logs but not their metrics files: each such
    log is an evaluation run of its own; a log whose metrics file is present adds nothing."""
    run = tmp_path / "download"
    shutil.copytree(EXAMPLES / CONSOLE, run)
    logkit.write(run / "logs" / "evaluation" / "evaluation-20210412113020-robomaker.log",
                 logkit.simulation_log(logkit.job_params(metrics_key=f"x/{EVALUATION}"),
                                       [(99.0, "lap_complete")]))
    race = "leaderboard/evaluation-20210501093000-RaCe.json"
    logkit.write(run / "logs" / "leaderboard" / "leaderboard-20210501093500-RaCe-robomaker.log",
                 logkit.simulation_log(logkit.job_params(metrics_key=race),
                                       [(8.5, "lap_complete"), (4.0, "off_track")]))
    record = assemble(run)
    assert [evaluation.source for evaluation in record.evaluations] == [
        EVALUATION, "logs/leaderboard/leaderboard-20210501093500-RaCe-robomaker.log"]
    assert [round(lap.time_ms / 100) for lap in record.evaluations[1].laps] == [85, 40]


def test_a_training_only_archive_is_told_it_holds_no_evaluation(tmp_path: Path) -> None:
    run = tmp_path / "training-only"
    logkit.write(run / "logs" / "training" / "training-20240501080000-Tr41-robomaker.log",
                 logkit.simulation_log(logkit.job_params("TRAINING"), [(20.0, "off_track")]))
    shutil.copytree(EXAMPLES / CONSOLE / "metrics" / "training", run / "metrics" / "training")
    archive = pack(run, tmp_path / "training-only.tar.gz")
    assert message_of(archive) == (f"{archive}: evaluation: there is no evaluation in it: no "
                                   "evaluation metrics file (metrics/evaluation/*.json or "
                                   "metrics/EvaluationMetrics-*.json) and no evaluation log")


def test_broken_log_lines_are_passed_over(tmp_path: Path) -> None:
    run = logkit.console_log_download(tmp_path / "pitstop-logs")
    log = next(run.rglob("*-robomaker.log"))
    with log.open("a") as out:
        out.write("SIM_TRACE_LOG:9,1,x,y\nSIM_TRACE_LOG:nan,1,2,3,4,5,6,7,8,True,nan,1,2,nan,x\n"
                  "Action space from file: [{'speed': 1e999}\n" + "{'WORLD_NAME': [[[[" * 500 + "\n")
    assert len(assemble(run).evaluations[0].laps) == 3


# ------------------------------------------------------------------ every missing fact at once

def test_every_missing_fact_is_named_in_one_message(tmp_path: Path) -> None:
    run = tmp_path / "bare"
    shutil.copytree(EXAMPLES / CONSOLE, run)
    for params in run.glob("*.yaml"):
        params.unlink()
    message = message_of(run)
    assert message == (f"{run}: WORLD_NAME, RACER_NAME, RACE_TYPE: the run's files do not say "
                       "(use --track, --racer, --race-type)")
    record = assemble(run, Overrides(track="reInvent2019", racer="Speedy",
                                     race_type="object_avoidance"))
    assert record.race_type == RaceType.OBJECT_AVOIDANCE


def test_the_cli_takes_race_type(tmp_path: Path) -> None:
    run = logkit.console_log_download(tmp_path / "pitstop-logs")
    result = CliRunner().invoke(cli, ["assemble", str(run), "--race-type", "head_to_bot"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.output)["race_type"] == "HEAD_TO_BOT"
    result = CliRunner().invoke(cli, ["assemble", str(run), "--race-type", "drag_race"])
    assert result.exit_code == 2


# ------------------------------------------------------------------ one run per push

def test_a_folder_of_several_runs_is_refused_with_the_runs_it_holds() -> None:
    message = message_of(EXAMPLES)
    assert message.startswith(f"{EXAMPLES}: holds 7 runs (blaze-ppo-droa, comet-sac-drfc, ")
    assert f"drboard push {EXAMPLES}/*/" in message


def test_pushing_the_examples_folder_itself_stores_nothing(tmp_path: Path) -> None:
    db = tmp_path / "board.sqlite"
    result = CliRunner().invoke(cli, ["--db", str(db), "push", str(EXAMPLES)])
    assert result.exit_code == 2
    assert "holds 7 runs" in result.output
    pulled = CliRunner().invoke(cli, ["--db", str(db), "boards", "--format", "json"])
    assert "reInvent2019" not in pulled.output


def test_the_same_evaluation_file_twice_counts_once(tmp_path: Path) -> None:
    run = tmp_path / CONSOLE
    shutil.copytree(EXAMPLES / CONSOLE, run)
    shutil.copy(run / EVALUATION, run / "metrics" / "evaluation" / "evaluation-copy (1).json")
    record = assemble(run)
    assert len(record.evaluations) == 1
    assert record.submission_id == assemble(EXAMPLES / CONSOLE).submission_id


def test_different_model_metadata_files_are_refused_by_name(tmp_path: Path) -> None:
    run = tmp_path / CONSOLE
    shutil.copytree(EXAMPLES / CONSOLE, run)
    other = json.loads((run / "model_metadata.json").read_text())
    other["action_space"] = other["action_space"][:2]
    logkit.write(run / "other-model" / "model_metadata.json", json.dumps(other))
    for params in run.glob("*.yaml"):
        params.write_text("".join(line for line in params.read_text().splitlines(keepends=True)
                                  if not line.startswith("MODEL_METADATA_FILE_S3_KEY")))
    message = message_of(run)
    assert ("model_metadata.json: holds the metadata of 2 models (model_metadata.json, "
            "other-model/model_metadata.json) and nothing in the evaluation's files names the one "
            "it ran: name it (--model other-model)") in message
    assert f"drboard push {run}/other-model" in message
    named = assemble(run, Overrides(model="other-model"))
    assert named.model_name == "other-model"
    assert named.design.action_space is not None and len(named.design.action_space.actions or []) == 2


def test_the_model_metadata_the_params_name_is_used(tmp_path: Path) -> None:
    run = tmp_path / CONSOLE
    shutil.copytree(EXAMPLES / CONSOLE, run)
    other = json.loads((run / "model_metadata.json").read_text())
    other["action_space"] = other["action_space"][:2]
    logkit.write(run / "model" / "model_metadata.json", json.dumps(other))
    for params in run.glob("*.yaml"):
        params.write_text(params.read_text().replace("speedy-ppo-console/model_metadata.json",
                                                     "speedy-ppo-console/model/model_metadata.json"))
    assert len(assemble(run).design.action_space.actions or []) == 2


def test_a_folder_and_its_archive_are_the_same_submission(tmp_path: Path) -> None:
    name = "drifter-ppo-drfc"  # no MODEL_NAME in its params: the model is named after the folder
    archive = pack(EXAMPLES / name, tmp_path / "download (3).tar.gz")
    from_archive, from_folder = assemble(archive), assemble(EXAMPLES / name)
    assert from_archive.model_name == from_folder.model_name == name
    assert from_archive.submission_id == from_folder.submission_id


def test_a_drfc_model_is_named_by_its_s3_prefix_not_the_default_folder(tmp_path: Path) -> None:
    run = tmp_path / "rl-deepracer-sagemaker"
    shutil.copytree(EXAMPLES / "lefty-ppo-drfc-cw", run)
    assert assemble(run).model_name == "lefty-ppo-drfc-cw"
    for params in run.glob("*.yaml"):
        params.write_text(params.read_text().replace("lefty-ppo-drfc-cw", "rl-deepracer-sagemaker"))
    assert assemble(run).model_name == "rl-deepracer-sagemaker"  # nothing better to go by
    assert assemble(run, Overrides(model="Lefty v2")).model_name == "Lefty v2"


def test_an_error_inside_an_archive_names_the_archive_then_the_file(tmp_path: Path) -> None:
    run = tmp_path / "ab12cd34"
    shutil.copytree(EXAMPLES / CONSOLE, run)
    (run / "model_metadata.json").write_text("{")
    archive = pack(run, tmp_path / "my-model.tar.gz")
    assert message_of(archive).startswith(f"{archive}: model_metadata.json: ")
