"""Each layout racers' downloads come in, written in its real format (tests/layoutkit.py), and
every fact the record states checked against the files: track, race type, racer, model, runs,
laps, best lap, completion, conditions, action space, hyperparameters, training, and where each
design fact came from. Where the files do not state a fact, the record says it is unknown."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import pytest
from drboard_assembler import AssemblyError, Overrides, Record, assemble
from drboard_assembler.record import lap_floor_ms

from tests import layoutkit as kit
from tests.downloadkit import (
    CONSOLE_EVAL,
    CONSOLE_EVAL_LOG,
    CONSOLE_EVALUATION,
    CONSOLE_TRAIN,
    CONSOLE_TRAIN_LOG,
    DROA_EVAL,
    DROA_EVALUATION,
    DROA_ID,
    DROA_LOG,
    DROA_TRAIN,
    DROA_TRAIN_LOG,
    UUID_EVAL,
    UUID_TRAIN,
    console_download,
    console_params,
    drfc_folder,
    droa_evaluation_download,
    droa_params,
    droa_solution_download,
    three_models,
)

#: The design facts a model's metadata (or what a job printed of it) states.
DESCRIBED = ("algorithm", "action_space", "sensors", "neural_network", "metadata_version")


def facts(record: Record) -> dict[str, Any]:
    """Every fact the record states, flat, for one comparison."""
    design, space = record.design, record.design.action_space
    return {
        "track": record.track, "direction": record.direction, "race_type": record.race_type.value,
        "racer": record.racer, "model": record.model_name, "layout": record.source_layout.value,
        "runs": [{
            "source": run.source,
            "laps": [(lap.time_ms, lap.completion_pct, lap.status, lap.off_track, lap.crashes, lap.resets)
                     for lap in run.laps],
            "best_lap_ms": run.best_lap_ms, "completion": run.best_completion_pct,
            "conditions": run.conditions.stated() if run.conditions else None,
            "named_by_params": run.named_by_params,
        } for run in record.evaluations],
        "algorithm": design.algorithm, "sensors": design.sensors,
        "action_space": None if space is None else (space.type, space.max_speed, space.max_steering,
                                                    len(space.actions or [])),
        "metadata_version": design.metadata_version,
        "hyperparameters": None if design.hyperparameters is None else
        design.hyperparameters.model_dump(exclude_none=True, exclude={"other"}),
        "sources": design.sources.model_dump() if design.sources else None,
        "training": None if record.training is None else (
            record.training.track, record.training.episodes, record.training.training_time_s),
        "provenance": sorted((source.role, source.path) for source in record.provenance),
    }


def expected_hyperparameters(raw: dict[str, Any]) -> dict[str, Any]:
    normalised = dict(raw)
    if normalised["loss_type"] == "mean squared error":
        normalised["loss_type"] = "mean_squared_error"
    return normalised


def message_of(path: Path, overrides: Overrides | None = None) -> str:
    with pytest.raises(AssemblyError) as caught:
        assemble(path, overrides)
    return str(caught.value)


# ------------------------------------------------------------------ the console, 2020 on

def console_run_facts(source: str = CONSOLE_EVAL, **changes: Any) -> dict[str, Any]:
    times = kit.lap_times_ms(CONSOLE_EVALUATION)
    return {
        "source": source,
        "laps": [(times[0], 100.0, "Lap complete", 1, 0, 1), (times[1], 100.0, "Lap complete", 0, 0, 0),
                 (times[2], 41.0, "Off track", 1, 0, 1)],
        "best_lap_ms": times[1], "completion": 100.0,
        "conditions": {"off_track_penalty_s": 5.0, "collision_penalty_s": 5.0, "max_resets": 10000,
                       "trials": 3, "continuous": False},
        "named_by_params": True, **changes,
    }


def test_console_download_every_fact_is_the_evaluated_models(tmp_path: Path) -> None:
    run = console_download(tmp_path / "pitstop-v3")
    record = assemble(run)
    assert facts(record) == {
        "track": "reInvent2019_track", "direction": None, "race_type": "TIME_TRIAL",
        "racer": "Pitstop", "model": "pitstop-v3", "layout": "console",
        "runs": [console_run_facts()],
        "algorithm": "clipped_ppo", "sensors": ["FRONT_FACING_CAMERA"],
        "action_space": ("discrete", 3.0, 30.0, 5), "metadata_version": "5",
        # the model's own, not the 0.999 / mean squared error / 10 epochs the evaluation printed
        "hyperparameters": expected_hyperparameters(kit.hyperparameters()),
        "sources": {"algorithm": "model_metadata.json", "action_space": "model_metadata.json",
                    "sensors": "model_metadata.json", "neural_network": "model_metadata.json",
                    "metadata_version": "model_metadata.json", "hyperparameters": "ip/hyperparameters.json"},
        "training": ("Vegas_track", 188, kit.training_span_s(kit.training_metrics(188))),
        "provenance": sorted([("evaluation_metrics", CONSOLE_EVAL), ("evaluation_params", UUID_EVAL),
                              ("hyperparameters", "ip/hyperparameters.json"),
                              ("model_metadata", "model_metadata.json"), ("simulation_log", CONSOLE_EVAL_LOG),
                              ("training_metrics", CONSOLE_TRAIN), ("training_params", UUID_TRAIN)]),
    }
    # the off-track's 5 s are in the first lap's time, as the simulator timed it
    assert record.evaluations[0].laps[0].time_ms == pytest.approx(11400 + 5000, abs=70)


def test_console_log_download_takes_hyperparameters_from_the_training_log(tmp_path: Path) -> None:
    """Logs only: the evaluation log names the run and prints the model; the training log
    holds the model's hyperparameters; the evaluation log's block is the evaluation worker's."""
    run = tmp_path / "pitstop-logs"
    kit.write(run / CONSOLE_EVAL_LOG, kit.evaluation_log(console_params(), CONSOLE_EVALUATION))
    hyper = kit.hyperparameters(discount_factor=0.9)
    kit.write(run / CONSOLE_TRAIN_LOG, kit.training_log(kit.FIVE_ACTIONS, hyper))
    record = assemble(run)
    assert facts(record) == {
        "track": "reInvent2019_track", "direction": None, "race_type": "TIME_TRIAL",
        "racer": "Pitstop", "model": "pitstop-v3", "layout": "plain",
        "runs": [console_run_facts(CONSOLE_EVAL_LOG) | {
            "laps": [(lap[0], lap[1], lap[2], lap[3], lap[4], lap[5])
                     for lap in console_run_facts()["laps"]]}],
        "algorithm": "clipped_ppo", "sensors": ["FRONT_FACING_CAMERA"],
        "action_space": ("discrete", 3.0, 30.0, 5), "metadata_version": "5",
        "hyperparameters": expected_hyperparameters(hyper),
        "sources": dict.fromkeys(DESCRIBED, CONSOLE_EVAL_LOG) | {"hyperparameters": CONSOLE_TRAIN_LOG},
        "training": None,
        "provenance": [("simulation_log", CONSOLE_EVAL_LOG), ("training_log", CONSOLE_TRAIN_LOG)],
    }


def test_an_evaluation_log_alone_states_no_hyperparameters(tmp_path: Path) -> None:
    run = tmp_path / "evaluation-log-only"
    continuous = {"speed": {"low": 1.0, "high": 3.5}, "steering_angle": {"low": -25, "high": 25}}
    kit.write(run / CONSOLE_EVAL_LOG, kit.evaluation_log(console_params(), CONSOLE_EVALUATION,
                                                         algorithm="sac", space=continuous))
    design = assemble(run).design
    assert design.hyperparameters is None  # not the 0.999 / alpha 0.2 the evaluation printed
    assert design.sources is not None and design.sources.hyperparameters is None
    assert design.algorithm == "sac" and design.action_space is not None
    assert (design.action_space.type, design.action_space.max_speed) == ("continuous", 3.5)


# ------------------------------------------------------------------ the console, 2019

def test_a_2019_evaluation_log_is_named_as_a_format_not_read(tmp_path: Path) -> None:
    run = tmp_path / "console-2019"
    log = "logs/evaluation/evaluation-20191128214015-onw2phM3ZUeIbdvt1tqChP-robomaker.log"
    kit.write(run / log, kit.ros_log_2019(console_params(), CONSOLE_EVALUATION))
    assert message_of(run) == (
        f"{run}: {log}: is a log of the 2019 format (parameters printed ROS-style, trace lines "
        "without status), which drboard does not read; it needs the evaluation's metrics file "
        "(metrics/evaluation/*.json) or its log as the simulation wrote it")


def test_a_2019_download_with_its_metrics_file_assembles_from_the_metrics(tmp_path: Path) -> None:
    run = tmp_path / "console-2019"
    log = "logs/evaluation/evaluation-20191128214015-onw2phM3ZUeIbdvt1tqChP-robomaker.log"
    kit.write(run / log, kit.ros_log_2019(console_params(), CONSOLE_EVALUATION))
    legacy = kit.metadata([{"steering_angle": action["steering_angle"], "speed": action["speed"]}
                           for action in kit.FIVE_ACTIONS])
    for key in ("version", "training_algorithm", "action_space_type", "neural_network"):
        del legacy[key]
    kit.write(run / "model_metadata.json", legacy)
    metrics = "metrics/evaluation/evaluation-20191128213802-onw2phM3ZUeIbdvt1tqChP.json"
    kit.write(run / metrics, kit.evaluation_metrics(CONSOLE_EVALUATION))
    record = assemble(run, Overrides(track="reInvent2019_track", racer="Pitstop", race_type="time_trial"))
    assert facts(record)["runs"] == [console_run_facts(metrics, conditions=None, named_by_params=None)]
    assert (record.design.algorithm, record.design.metadata_version) == ("clipped_ppo", None)
    assert record.design.hyperparameters is None
    assert [source.path for source in record.provenance] == [metrics, "model_metadata.json"]


# ------------------------------------------------------------------ DeepRacer-for-Cloud

def test_drfc_fastcar_lap_of_38_043_s_assembles_with_every_fact(tmp_path: Path) -> None:
    record = assemble(drfc_folder(tmp_path / "fastcar", 38043))
    assert facts(record) == {
        "track": "Spain_track", "direction": None, "race_type": "TIME_TRIAL", "racer": "FastCar",
        "model": "fastcar", "layout": "drfc",
        "runs": [{"source": "metrics/EvaluationMetrics-20240708193012.json",
                  "laps": [(38043, 100.0, "In progress", 0, 0, 0), (38043, 100.0, "In progress", 0, 0, 0),
                           (38043, 100.0, "Lap complete", 0, 0, 0)],
                  "best_lap_ms": 38043, "completion": 100.0,
                  "conditions": {"off_track_penalty_s": 3.0, "collision_penalty_s": 5.0, "max_resets": 0,
                                 "trials": 3, "continuous": True},
                  "named_by_params": True}],
        "algorithm": "clipped_ppo", "sensors": ["FRONT_FACING_CAMERA"],
        "action_space": ("discrete", 1.5, 20.0, 3), "metadata_version": "5",
        "hyperparameters": expected_hyperparameters(kit.hyperparameters(batch_size=64)),
        "sources": dict.fromkeys(DESCRIBED, "model/model_metadata.json")
        | {"hyperparameters": "ip/hyperparameters.json"},
        "training": ("Spain_track", 240, kit.training_span_s(kit.training_metrics(240))),
        "provenance": sorted([("evaluation_metrics", "metrics/EvaluationMetrics-20240708193012.json"),
                              ("evaluation_params", "evaluation_params.yaml"),
                              ("hyperparameters", "ip/hyperparameters.json"),
                              ("model_metadata", "model/model_metadata.json"),
                              ("training_metrics", "metrics/TrainingMetrics.json"),
                              ("training_params", "training_params.yaml")]),
    }


def test_the_lap_floor_comes_from_the_shortest_path_not_the_centre_line() -> None:
    # Spain: 60.00 m of centre line, 49.24 m of shortest path; at 1.5 m/s the centre line
    # takes 40 s, which the 38.043 s lap beats by cutting corners; the shortest path 32.8 s.
    floor = lap_floor_ms("Spain_track", 1.5)
    assert floor is not None and 32_000 < floor < 38_043 < 60.00 / 1.5 * 1000
    assert lap_floor_ms("Spain_track", None) == pytest.approx(49.24 / 4.0 * 1000)  # unknown: the bound


def test_a_lap_under_half_the_floor_is_still_refused(tmp_path: Path) -> None:
    floor = lap_floor_ms("Spain_track", 1.5)
    assert floor is not None
    message = message_of(drfc_folder(tmp_path / "fastcar", int(floor / 2) - 100))
    assert "is faster than possible: the shortest lap of Spain_track (49.24 m)" in message


# ------------------------------------------------------------------ DeepRacer on AWS

def droa_run_facts(**changes: Any) -> dict[str, Any]:
    times = kit.lap_times_ms(DROA_EVALUATION)
    return {"source": DROA_EVAL,
            "laps": [(times[0], 100.0, "Lap complete", 1, 0, 1), (times[1], 100.0, "Lap complete", 0, 0, 0),
                     (times[2], 100.0, "Lap complete", 0, 0, 0)],
            "best_lap_ms": min(times), "completion": 100.0,
            "conditions": {"max_resets": 10000, "trials": 3, "continuous": False},
            "named_by_params": True, **changes}


def droa_facts(log: str = DROA_LOG, **changes: Any) -> dict[str, Any]:
    return {
        "track": "Spain_track", "direction": None, "race_type": "TIME_TRIAL", "racer": "Duckworth",
        "model": "Progress-Test-B-1", "layout": "droa", "runs": [droa_run_facts()],
        "algorithm": "clipped_ppo", "sensors": ["FRONT_FACING_CAMERA"],
        "action_space": ("discrete", 2.5, 25.0, 5), "metadata_version": "6",
        "hyperparameters": None,
        "sources": dict.fromkeys(DESCRIBED, log) | {"hyperparameters": None},
        "training": None,
        "provenance": sorted([("evaluation_metrics", DROA_EVAL), ("simulation_log", log)]),
        **changes,
    }


def test_droa_evaluation_download_every_fact(tmp_path: Path) -> None:
    record = assemble(droa_evaluation_download(tmp_path / DROA_ID))
    assert facts(record) == droa_facts()
    assert len(record.evaluations) == 1  # the metrics file and its log are one evaluation


def test_droa_solution_download_takes_the_training_jobs_hyperparameters(tmp_path: Path) -> None:
    hyper = kit.hyperparameters(num_epochs=3, discount_factor=0.95)
    run = droa_solution_download(tmp_path / DROA_ID, hyper)
    record = assemble(run)
    assert facts(record) == droa_facts(
        hyperparameters=expected_hyperparameters(hyper),
        sources=droa_facts()["sources"] | {"hyperparameters": DROA_TRAIN_LOG},
        training=("Spain_track", 580, kit.training_span_s(kit.training_metrics(580))),
        provenance=sorted([("evaluation_metrics", DROA_EVAL), ("simulation_log", DROA_LOG),
                           ("training_log", DROA_TRAIN_LOG), ("training_metrics", DROA_TRAIN)]))


@pytest.mark.parametrize("renamed", ["evaluation-log.txt", "logs/sim-log", "Duckworth eval (1).TXT"])
def test_a_renamed_log_is_found_by_what_it_holds(tmp_path: Path, renamed: str) -> None:
    record = assemble(droa_evaluation_download(tmp_path / DROA_ID, log_name=renamed))
    assert facts(record) == droa_facts(renamed)


def test_a_log_of_laps_with_no_action_space_leaves_the_design_unknown(tmp_path: Path) -> None:
    """An evaluation job's download whose log holds the laps but prints no action space (and
    no metadata file beside it): the run ranks, its design unknown."""
    run = tmp_path / DROA_ID
    kit.write(run / DROA_LOG, kit.evaluation_log(droa_params(), DROA_EVALUATION, space=False,
                                                 sensor_line=False, prefix=kit.DROA_PREFIX))
    record = assemble(run)
    times = kit.lap_times_ms(DROA_EVALUATION)
    assert facts(record) == droa_facts(
        runs=[droa_run_facts(source=DROA_LOG, laps=[(times[0], 100.0, "Lap complete", 1, 0, 1),
                                                    (times[1], 100.0, "Lap complete", 0, 0, 0),
                                                    (times[2], 100.0, "Lap complete", 0, 0, 0)])],
        algorithm=None, sensors=None, action_space=None, metadata_version=None,
        sources=dict.fromkeys(droa_facts()["sources"]), provenance=[("simulation_log", DROA_LOG)],
        layout="plain")


def test_a_cloudwatch_csv_export_is_named_as_a_format_not_read(tmp_path: Path) -> None:
    run = tmp_path / "export"
    text = kit.evaluation_log(droa_params(), DROA_EVALUATION)
    kit.write(run / "logs-insights-results.csv", kit.cloudwatch_csv(text))
    assert message_of(run) == (
        f"{run}: logs-insights-results.csv: is a CloudWatch CSV export, which drboard does not read; "
        "it needs the evaluation's metrics file (metrics/evaluation/*.json) or its log as the "
        "simulation wrote it")


# ------------------------------------------------------------------ renamed and repeated files

def test_a_renamed_metrics_file_and_its_log_are_one_evaluation(tmp_path: Path) -> None:
    run = console_download(tmp_path / "pitstop-v3")
    (run / CONSOLE_EVAL).rename(run / "my best run.json")
    record = assemble(run)
    assert facts(record)["runs"] == [console_run_facts("my best run.json")]
    assert [source.role for source in record.provenance].count("simulation_log") == 1


def test_a_renamed_metrics_file_without_its_log_is_flagged_as_not_named(tmp_path: Path) -> None:
    run = console_download(tmp_path / "pitstop-v3", logs=False)
    (run / CONSOLE_EVAL).rename(run / "metrics" / "best.json")
    assert facts(assemble(run))["runs"] == [console_run_facts("metrics/best.json", named_by_params=False,
                                                              conditions=None)]


def test_a_copied_metrics_file_counts_once(tmp_path: Path) -> None:
    run = console_download(tmp_path / "pitstop-v3")
    shutil.copy(run / CONSOLE_EVAL, run / "metrics" / "evaluation" / "evaluation-copy (1).json")
    (run / "metrics" / "evaluation" / "reformatted.json").write_text(
        json.dumps(json.loads((run / CONSOLE_EVAL).read_text()), indent=4))
    assert facts(assemble(run))["runs"] == [console_run_facts()]


def test_identical_training_metrics_files_count_once(tmp_path: Path) -> None:
    run = console_download(tmp_path / "pitstop-v3")
    shutil.copy(run / CONSOLE_TRAIN, run / "metrics" / "training" / "training-copy.json")
    training = assemble(run).training
    assert training is not None and training.episodes == 188


# ------------------------------------------------------------------ more than one model

def test_a_sibling_models_metadata_gives_way_to_what_the_evaluation_printed(tmp_path: Path) -> None:
    """The folder's model_metadata.json is a sibling model's (one speed differs): the action
    space is the one the evaluation log printed, and the metadata file is not used."""
    sibling = [dict(action) for action in kit.FIVE_ACTIONS]
    sibling[2]["speed"] = 3.5
    run = console_download(tmp_path / "pitstop-v3", space=sibling)
    record = assemble(run)
    space = record.design.action_space
    assert space is not None and (space.max_speed, len(space.actions or [])) == (3.0, 5)
    assert record.design.sources is not None
    assert record.design.sources.action_space == CONSOLE_EVAL_LOG
    assert record.design.sources.sensors == CONSOLE_EVAL_LOG
    assert record.design.sources.hyperparameters == "ip/hyperparameters.json"
    assert "model_metadata" not in {source.role for source in record.provenance}
    assert facts(record)["runs"] == [console_run_facts()]


def test_three_models_in_a_folder_the_evaluation_names_its_own(tmp_path: Path) -> None:
    record = assemble(three_models(tmp_path / "models-download"))
    assert (record.model_name, record.racer, record.track) == ("bravo", "Pitstop", "reInvent2019_track")
    space = record.design.action_space
    assert space is not None and space.max_speed == 3.0
    assert record.design.hyperparameters is not None and record.design.hyperparameters.batch_size == 96
    assert record.training is not None and record.training.episodes == 150
    sources = record.design.sources
    assert sources is not None
    assert (sources.action_space, sources.hyperparameters) == ("models/bravo/model_metadata.json",
                                                                "models/bravo/ip/hyperparameters.json")
    assert facts(record)["runs"] == [console_run_facts()]
    assert {source.path for source in record.provenance if source.role == "training_metrics"} == {
        "models/bravo/metrics/training/training-20240501080000-bravo.json"}


def test_three_models_and_nothing_names_one_is_refused_with_what_to_type(tmp_path: Path) -> None:
    run = three_models(tmp_path / "models-download", model_name=None)
    assert message_of(run) == (
        f"{run}: model_metadata.json: holds the metadata of 3 models (models/alpha/model_metadata.json, "
        "models/bravo/model_metadata.json, models/charlie/model_metadata.json) and nothing in the "
        "evaluation's files names the one it ran: name it (--model alpha) or push the evaluated "
        f"model's folder with the evaluation in it (e.g. drboard push {run}/models/alpha)")
    record = assemble(run, Overrides(model="charlie"))
    assert record.model_name == "charlie"
    assert record.design.hyperparameters is not None and record.design.hyperparameters.batch_size == 128
    # charlie's metadata disagrees with the action space the evaluation printed: the log's holds
    assert record.design.action_space is not None and record.design.action_space.max_speed == 3.0


# ------------------------------------------------------------------ refusals that say what to type

def test_training_only_params_name_the_training_track_in_the_refusal(tmp_path: Path) -> None:
    run = drfc_folder(tmp_path / "fastcar", 38043)
    (run / "evaluation_params.yaml").unlink()
    assert message_of(run) == (
        f"{run}: WORLD_NAME: the evaluation's files do not say its track; the training ran on "
        "Spain_track (use --track Spain_track if the evaluation ran there too)")
    record = assemble(run, Overrides(track="Spain_track"))
    assert (record.track, record.racer, record.race_type.value) == ("Spain_track", "FastCar", "TIME_TRIAL")
    assert record.evaluations[0].conditions is None  # no evaluation parameters: unknown
