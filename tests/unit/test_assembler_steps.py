"""Each step of the assembler on its own: find the files, read the parameters and logs, choose
the evaluated model, the evaluations, the design, the conditions, what the evaluation names."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
from drboard_assembler.choice import choose_model
from drboard_assembler.conditions import conditions_of
from drboard_assembler.design import Facts, NamedFile, build_design, metadata_facts, printed_facts
from drboard_assembler.errors import AssemblyError
from drboard_assembler.evaluations import collect_runs
from drboard_assembler.identity import Overrides, identify
from drboard_assembler.inputs import Reader, read_inputs
from drboard_assembler.layout import find_run_files
from drboard_assembler.logs import read_log
from drboard_assembler.params import params_from_values
from drboard_assembler.record import Conditions

from tests import layoutkit as kit
from tests.downloadkit import console_params

EVALUATION = kit.Evaluation((kit.LapSpec(10.0, off_tracks=1), kit.LapSpec(9.5)), off_track_penalty_s=3.0)


def inputs_of(root: Path) -> tuple[Any, Any, Any]:
    files = find_run_files(root)
    reader = Reader(files)
    return files, reader, read_inputs(files, reader)


# ------------------------------------------------------------------ 1. find the files

def test_files_no_name_describes_are_known_by_what_they_hold(tmp_path: Path) -> None:
    kit.write(tmp_path / "best run.json", kit.evaluation_metrics(EVALUATION))
    kit.write(tmp_path / "worker 2.json", kit.training_metrics(30))
    kit.write(tmp_path / "eval-log.txt", kit.evaluation_log(console_params(), EVALUATION))
    kit.write(tmp_path / "sagemaker", kit.training_log(kit.FIVE_ACTIONS, kit.hyperparameters()))
    kit.write(tmp_path / "notes.txt", "my best model yet\n")
    kit.write(tmp_path / "reward_function.py", "def reward_function(params):\n    return 1.0\n")
    kit.write(tmp_path / "sim-trace" / "evaluation-simtrace" / "0-iteration.csv",
              "episode,steps,X,Y\n0,1,0.1,0.2\n")
    (tmp_path / "model.pb").write_bytes(b"\x00\x01SIM_TRACE_LOG")
    files = find_run_files(tmp_path)
    assert [files.name(p) for p in files.evaluation_metrics] == ["best run.json"]
    assert [files.name(p) for p in files.training_metrics] == ["worker 2.json"]
    assert sorted(files.name(p) for p in files.logs) == ["eval-log.txt", "sagemaker"]


# ------------------------------------------------------------------ 2. read the parameters and logs

def test_a_log_says_which_job_wrote_it_and_what_it_loaded(tmp_path: Path) -> None:
    evaluation = read_log(kit.write(tmp_path / "e.log", kit.evaluation_log(
        console_params(), EVALUATION, metadata_key="data/models/bravo/model/model_metadata.json")), "e.log")
    training = read_log(kit.write(tmp_path / "t.log",
                                  kit.training_log(kit.FIVE_ACTIONS, kit.hyperparameters())), "t.log")
    assert (evaluation.job, training.job) == ("evaluation", "training")
    assert evaluation.metadata_key == "data/models/bravo/model/model_metadata.json"
    assert evaluation.ros_params["RACER_NAME"] == "Pitstop"
    assert evaluation.unread_format is None and training.unread_format is None


def test_a_logs_laps_carry_its_resets_and_a_continuous_evaluations_laps(tmp_path: Path) -> None:
    continuous = kit.Evaluation((kit.LapSpec(10.0, crashes=1), kit.LapSpec(9.5), kit.LapSpec(9.7)),
                                continuous=True)
    log = read_log(kit.write(tmp_path / "e.log", kit.evaluation_log(console_params(), continuous)), "e.log")
    laps = log.laps()
    assert [(lap.status, lap.crashes, lap.resets) for lap in laps] == [
        ("In progress", 1, 1), ("In progress", 0, 0), ("Lap complete", 0, 0)]
    # the log's times are to the millisecond its timestamps print
    assert [lap.time_ms for lap in laps] == pytest.approx(kit.lap_times_ms(continuous), abs=2)


@pytest.mark.parametrize(("text", "unread"), [
    (kit.ros_log_2019(console_params(), EVALUATION),
     "a log of the 2019 format (parameters printed ROS-style, trace lines without status)"),
    (kit.cloudwatch_csv(kit.evaluation_log(console_params(), EVALUATION)), "a CloudWatch CSV export"),
])
def test_formats_not_read_are_named(tmp_path: Path, text: str, unread: str) -> None:
    log = read_log(kit.write(tmp_path / "x.log", text), "x.log")
    assert log.unread_format == unread
    assert log.laps() == []


# ------------------------------------------------------------------ 3. choose the evaluated model

def models(root: Path, log_params: dict[str, Any], *,
           metadata_key: str = "m/model/model_metadata.json") -> Path:
    for name, speed in (("alpha", 2.0), ("bravo", 3.0)):
        kit.write(root / name / "model_metadata.json", kit.metadata(kit.actions((0.0, speed))))
    kit.write(root / "logs" / "e.log", kit.evaluation_log(log_params, EVALUATION, metadata_key=metadata_key))
    return root


@pytest.mark.parametrize(("params", "key"), [
    ({"MODEL_NAME": "bravo"}, "m/model/model_metadata.json"),  # its name
    ({"MODEL_NAME": "x"}, "data/models/bravo/model/model_metadata.json"),  # the key it loaded
    ({"MODEL_NAME": "x", "MODEL_S3_PREFIX": "data/models/bravo"}, "m/model/model_metadata.json"),
])
def test_the_model_the_evaluation_names_is_chosen(tmp_path: Path, params: dict[str, Any], key: str) -> None:
    files, reader, inputs = inputs_of(models(tmp_path, console_params(**params), metadata_key=key))
    model = choose_model(files, inputs, reader, "here")
    assert model.metadata == tmp_path / "bravo" / "model_metadata.json"
    assert model.others == (tmp_path / "alpha",)


def test_a_model_nothing_names_is_refused_with_the_folders(tmp_path: Path) -> None:
    files, reader, inputs = inputs_of(models(tmp_path, console_params(MODEL_NAME="x")))
    with pytest.raises(AssemblyError) as refused:
        choose_model(files, inputs, reader, "here")
    assert "alpha/model_metadata.json, bravo/model_metadata.json" in str(refused.value)
    assert "--model alpha" in str(refused.value)


# ------------------------------------------------------------------ 4. the evaluations

def test_a_log_joins_the_metrics_file_of_its_laps_and_a_log_of_other_laps_is_a_run(tmp_path: Path) -> None:
    other = kit.Evaluation((kit.LapSpec(12.0),))
    kit.write(tmp_path / "renamed.json", kit.evaluation_metrics(EVALUATION))
    kit.write(tmp_path / "a.log", kit.evaluation_log(console_params(), EVALUATION))
    kit.write(tmp_path / "b.log", kit.evaluation_log(
        console_params(METRICS_S3_OBJECT_KEY="x/leaderboard-race.json"), other))
    files, reader, inputs = inputs_of(tmp_path)
    runs = collect_runs(files, inputs, choose_model(files, inputs, reader, "here"), reader)
    assert [(run.run.source, run.log.name if run.log else None) for run in runs] == [
        ("renamed.json", "a.log"), ("b.log", "b.log")]
    assert runs[0].run.conditions == Conditions(off_track_penalty_s=5.0, collision_penalty_s=5.0,
                                                max_resets=10000, trials=3, continuous=False,
                                                source="a.log")


# ------------------------------------------------------------------ 5. the design

def facts(source: str, top_speed: float) -> Facts:
    return metadata_facts(NamedFile(source, json.dumps(kit.metadata(kit.actions((0.0, top_speed)))).encode()))


def test_the_metadata_counts_unless_what_the_evaluation_printed_disagrees() -> None:
    agreeing = build_design(facts("model_metadata.json", 3.0), facts("e.log", 3.0), None, None, None)
    assert agreeing.sources is not None and agreeing.sources.action_space == "model_metadata.json"
    sibling = build_design(facts("model_metadata.json", 3.5), facts("e.log", 3.0), None, None, None)
    assert sibling.max_speed == 3.0
    assert sibling.sources is not None and sibling.sources.action_space == "e.log"


def test_hyperparameters_come_from_the_file_else_the_training_log_else_are_unknown(tmp_path: Path) -> None:
    hyper = kit.hyperparameters(lr=0.001)
    training = read_log(kit.write(tmp_path / "t.log", kit.training_log(kit.FIVE_ACTIONS, hyper)), "t.log")
    evaluation = read_log(kit.write(tmp_path / "e.log", kit.evaluation_log(console_params(), EVALUATION)),
                          "e.log")
    assert evaluation.hyperparameters is not None  # printed, but the evaluation worker's
    from_log = build_design(None, printed_facts(evaluation), None, None, training)
    assert from_log.hyperparameters is not None and from_log.hyperparameters.lr == 0.001
    unknown = build_design(None, printed_facts(evaluation), None, None, None)
    assert unknown.hyperparameters is None and unknown.sources is not None
    assert unknown.sources.hyperparameters is None
    nothing = build_design(None, None, None, None, None)
    assert (nothing.algorithm, nothing.action_space, nothing.sensors) == (None, None, None)


# ------------------------------------------------------------------ 6. the conditions

def test_conditions_are_what_the_evaluation_parameters_state() -> None:
    params = params_from_values({"JOB_TYPE": "EVALUATION", "OFF_TRACK_PENALTY": "5.00",
                                 "IS_CONTINUOUS": "true", "OBJECT_POSITIONS": ["0.2,-1", "0.5,1"],
                                 "NUMBER_OF_OBSTACLES": "6"}, "eval_params.yaml")
    assert conditions_of(params) == Conditions(off_track_penalty_s=5.0, continuous=True, obstacles=2,
                                               source="eval_params.yaml")
    assert conditions_of(params_from_values({"JOB_TYPE": "EVALUATION"}, "e.yaml")) is None
    training = params_from_values({"JOB_TYPE": "TRAINING", "NUMBER_OF_TRIALS": 3}, "t.yaml")
    assert conditions_of(training) is None
    with pytest.raises(AssemblyError) as refused:
        conditions_of(params_from_values({"JOB_TYPE": "EVALUATION", "NUMBER_OF_RESETS": "-1"}, "e.yaml"))
    assert str(refused.value) == "e.yaml: NUMBER_OF_RESETS: expected a number from 0 to 1e+06, found '-1'"


# ------------------------------------------------------------------ 7. what the evaluation names

def test_a_track_only_the_training_names_is_named_in_the_refusal() -> None:
    training = [params_from_values({"JOB_TYPE": "TRAINING", "WORLD_NAME": "reInvent2019_track",
                                    "RACER_NAME": "Ada"}, "training_params.yaml")]
    with pytest.raises(AssemblyError) as refused:
        identify(None, [], training, Overrides(), "here", "model")
    assert str(refused.value) == ("here: WORLD_NAME: the evaluation's files do not say its track; the "
                                  "training ran on reInvent2019_track (use --track reInvent2019_track "
                                  "if the evaluation ran there too)")
