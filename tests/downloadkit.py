"""Racers' downloads of each producer, whole folders built with layoutkit: the console's model
download with its logs, a DeepRacer-for-Cloud model folder, DeepRacer on AWS evaluation and
solution downloads, and a folder of three models. Used by the layout tests and the fuzzer."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tests import layoutkit as kit

UUID_EVAL = "eval_params_3f9a1c2e-8b7d-4e6f-9a0b-1c2d3e4f5a6b.yaml"
UUID_TRAIN = "training_params_7c6b5a49-3829-4f1e-8d7c-6b5a49382910.yaml"
CONSOLE_EVAL = "metrics/evaluation/evaluation-20240501101010-QkJ3xYzAbCdEfGhIjKlMnO.json"
CONSOLE_EVAL_LOG = "logs/evaluation/evaluation-20240501101502-QkJ3xYzAbCdEfGhIjKlMnO-robomaker.log"
CONSOLE_TRAIN = "metrics/training/training-20240501080000-Tr41nXyZaBcDeFgHiJkLmN.json"
CONSOLE_TRAIN_LOG = "logs/training/training-20240501080003-Tr41nXyZaBcDeFgHiJkLmN-sagemaker.log"
S3 = "data-6b1e2c0a-5d44-4b7e-9a1f-3c2d8e7f6a51/models/pitstop-v3"

CONSOLE_EVALUATION = kit.Evaluation((kit.LapSpec(11.4, off_tracks=1), kit.LapSpec(10.9),
                                     kit.LapSpec(5.1, end="off_track", progress=41.0)),
                                    off_track_penalty_s=5.0)


def console_params(**changes: Any) -> dict[str, Any]:
    return {"NUMBER_OF_TRIALS": "3", "RACER_NAME": "Pitstop", "CAR_NAME": "Pitstop-DR",
            "WORLD_NAME": "reInvent2019_track", "MODEL_S3_PREFIX": f"{S3}/sagemaker-robomaker-artifacts",
            "RACE_TYPE": "TIME_TRIAL", "METRICS_S3_OBJECT_KEY": f"{S3}/{CONSOLE_EVAL}",
            "MODEL_NAME": "pitstop-v3", "VIDEO_JOB_TYPE": "EVALUATION", "JOB_TYPE": "EVALUATION",
            "NUMBER_OF_RESETS": "10000", "IS_CONTINUOUS": "false", "OFF_TRACK_PENALTY": "5.0",
            "COLLISION_PENALTY": "5.0", "BODY_SHELL_TYPE": "deepracer", **changes}


def console_download(folder: Path, *, space: Any = None, hyper: dict[str, Any] | None = None,
                     evaluation: kit.Evaluation = CONSOLE_EVALUATION, logs: bool = True) -> Path:
    """A console model download (metadata, hyperparameters, params, metrics) with its logs."""
    hyper = hyper or kit.hyperparameters()
    kit.write(folder / "model_metadata.json", kit.metadata(space, version="5"))
    kit.write(folder / "ip" / "hyperparameters.json", hyper)
    kit.write(folder / UUID_TRAIN, kit.console_yaml({
        "WORLD_NAME": "Vegas_track", "RACE_TYPE": "TIME_TRIAL", "JOB_TYPE": "TRAINING",
        "RACER_NAME": "Pitstop",
        "MODEL_METADATA_FILE_S3_KEY": f"{S3}/model_metadata.json", "NUMBER_OF_EPISODES": "0",
        "METRICS_S3_OBJECT_KEY": f"{S3}/{CONSOLE_TRAIN}"}))
    kit.write(folder / UUID_EVAL, kit.console_yaml(console_params()))
    kit.write(folder / CONSOLE_TRAIN, kit.training_metrics(188))
    kit.write(folder / CONSOLE_EVAL, kit.evaluation_metrics(evaluation))
    if logs:
        kit.write(folder / CONSOLE_EVAL_LOG, kit.evaluation_log(
            console_params(), evaluation, space=kit.FIVE_ACTIONS,
            metadata_key=f"{S3}/sagemaker-robomaker-artifacts/model/model_metadata.json"))
        kit.write(folder / CONSOLE_TRAIN_LOG, kit.training_log(kit.FIVE_ACTIONS, hyper))
    return folder


def drfc_folder(folder: Path, lap_ms: int, *, top_speed: float = 1.5, world: str = "Spain_track") -> Path:
    """A DeepRacer-for-Cloud model folder as its upload writes it, evaluated with DRfC's
    default car name."""
    space = kit.actions((-20.0, 1.0), (0.0, top_speed), (20.0, 1.0))
    kit.write(folder / "model" / "model_metadata.json", kit.metadata(space, version="5"))
    kit.write(folder / "ip" / "hyperparameters.json", kit.hyperparameters(batch_size=64))
    kit.write(folder / "training_params.yaml", kit.typed_yaml({
        "AWS_REGION": "us-east-1", "CAR_NAME": "FastCar", "RACE_TYPE": "TIME_TRIAL", "WORLD_NAME": world,
        "JOB_TYPE": "TRAINING",
        "METRICS_S3_OBJECT_KEY": "rl-deepracer-sagemaker/metrics/TrainingMetrics.json",
        "MODEL_METADATA_FILE_S3_KEY": "rl-deepracer-sagemaker/model/model_metadata.json",
        "SAGEMAKER_SHARED_S3_PREFIX": "rl-deepracer-sagemaker"}))
    kit.write(folder / "evaluation_params.yaml", kit.typed_yaml({
        "AWS_REGION": "us-east-1", "CAR_NAME": "FastCar", "DISPLAY_NAME": ["FastCar"],
        "RACER_NAME": ["FastCar"],
        "MODEL_S3_PREFIX": ["rl-deepracer-sagemaker"], "JOB_TYPE": "EVALUATION", "RACE_TYPE": "TIME_TRIAL",
        "METRICS_S3_OBJECT_KEY": ["rl-deepracer-sagemaker/metrics/EvaluationMetrics-20240708193012.json"],
        "WORLD_NAME": [world], "NUMBER_OF_TRIALS": 3, "IS_CONTINUOUS": True, "NUMBER_OF_RESETS": 0,
        "OFF_TRACK_PENALTY": 3.0, "COLLISION_PENALTY": 5.0}))
    kit.write(folder / "metrics" / "TrainingMetrics.json", kit.training_metrics(240))
    entries = [{"completion_percentage": 100, "metric_time": 7000 + (n + 1) * lap_ms,
                "start_time": 7000 + n * lap_ms, "elapsed_time_in_milliseconds": lap_ms,
                "episode_status": "In progress" if n < 2 else "Lap complete",
                "crash_count": 0, "immobilized_count": 0, "off_track_count": 0, "reversed_count": 0,
                "reset_count": 0, "trial": n + 1} for n in range(3)]
    kit.write(folder / "metrics" / "EvaluationMetrics-20240708193012.json", {"metrics": entries})
    return folder


DROA_ID = "9oJ3QbS0SYm7Iag"
DROA_EVAL = f"metrics/evaluation/2026-03-07T17:52:00.898Z-deepracerindy-evaluation-{DROA_ID}.json"
DROA_LOG = f"logs/evaluation/2026-03-07T17:59:20.610Z-deepracerindy-evaluation-{DROA_ID}-simulation.log"
DROA_TRAIN = "metrics/training/2026-03-06T18:33:59.511Z-deepracerindy-training-ACGVRmRuFNU9NkQ.json"
DROA_TRAIN_LOG = ("logs/training/2026-03-06T20:36:57.936Z-deepracerindy-training-ACGVRmRuFNU9NkQ"
                  "-simulation.log")
DROA_EVALUATION = kit.Evaluation((kit.LapSpec(28.4, off_tracks=1), kit.LapSpec(28.6), kit.LapSpec(28.3)),
                                 off_track_penalty_s=2.0, first_start_s=37.3)
DROA_SPACE = kit.actions((-25.0, 1.0), (-10.0, 2.0), (0.0, 2.5), (10.0, 2.0), (25.0, 1.0))
DROA_PREFIX = "admin19c0b9859c/models/ACGVRmRuFNU9NkQ"


def droa_params(job: str = "EVALUATION", **changes: Any) -> dict[str, Any]:
    return {"AWS_REGION": "eu-central-1", "JOB_TYPE": job,
            "METRICS_S3_OBJECT_KEY": [f"{DROA_PREFIX}/{DROA_EVAL}"], "MODEL_NAME": "Progress-Test-B-1",
            "VIDEO_JOB_TYPE": job, "RACER_NAME": "Duckworth", "WORLD_NAME": "Spain_track",
            "RACE_TYPE": "TIME_TRIAL", "MODEL_S3_PREFIX": [f"{DROA_PREFIX}/sagemaker-artifacts/"],
            "NUMBER_OF_TRIALS": 3, "EVAL_CHECKPOINT": "last", "NUMBER_OF_RESETS": 10000,
            "IS_CONTINUOUS": False,
            "MODEL_METADATA_FILE_S3_KEY": [f"{DROA_PREFIX}/sagemaker-artifacts/model/model_metadata.json"],
            **changes}


def droa_evaluation_download(folder: Path, *, log_name: str = DROA_LOG, space: Any = None,
                             sensor_line: bool = True) -> Path:
    """A DeepRacer on AWS evaluation download: the evaluation's metrics and its log only."""
    kit.write(folder / DROA_EVAL, kit.evaluation_metrics(DROA_EVALUATION))
    kit.write(folder / log_name, kit.evaluation_log(
        droa_params(), DROA_EVALUATION, space=DROA_SPACE if space is None else space,
        prefix=kit.DROA_PREFIX, version="6.0", sensor_line=sensor_line,
        metadata_key=f"{DROA_PREFIX}/sagemaker-artifacts/model/model_metadata.json"))
    return folder


def three_models(folder: Path, *, model_name: str | None = "bravo") -> Path:
    """Three models' folders and, at the top, the evaluation of one of them."""
    speeds = {"alpha": 2.0, "bravo": 3.0, "charlie": 4.0}
    for name, speed in speeds.items():
        model = folder / "models" / name
        kit.write(model / "model_metadata.json",
                  kit.metadata(kit.actions((-30.0, 1.0), (0.0, speed), (30.0, 1.0))))
        kit.write(model / "ip" / "hyperparameters.json", kit.hyperparameters(batch_size=int(speed * 32)))
        kit.write(model / "metrics" / "training" / f"training-20240501080000-{name}.json",
                  kit.training_metrics(int(speed * 50)))
    params = console_params(MODEL_NAME=model_name) if model_name else {
        key: value for key, value in console_params(MODEL_S3_PREFIX="models/m").items()
        if key != "MODEL_NAME"}
    kit.write(folder / CONSOLE_EVAL, kit.evaluation_metrics(CONSOLE_EVALUATION))
    kit.write(folder / CONSOLE_EVAL_LOG, kit.evaluation_log(
        params, CONSOLE_EVALUATION, space=kit.actions((-30.0, 1.0), (0.0, 3.0), (30.0, 1.0)),
        metadata_key="models/m/model/model_metadata.json"))
    return folder


def droa_solution_download(folder: Path, hyper: dict[str, Any]) -> Path:
    """A DeepRacer on AWS solution download: the evaluation download, with the training job's
    metrics and its simulation log (which prints the model's hyperparameters)."""
    run = droa_evaluation_download(folder)
    kit.write(run / DROA_TRAIN, kit.training_metrics(580))
    lines = [repr(droa_params("TRAINING", METRICS_S3_OBJECT_KEY=[f"{DROA_PREFIX}/{DROA_TRAIN}"])),
             *kit.training_log(DROA_SPACE, hyper).splitlines()]
    kit.write(run / DROA_TRAIN_LOG, "".join(kit.DROA_TRAINING_PREFIX + line + "\n" for line in lines))
    return run
