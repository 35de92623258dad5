"""Every value bounded where it is read: names that are not UTF-8, training timestamps of any
spread, training tracks of any length, trainings of over a million entries. Each case ends in a
record or in one clean message, never a traceback."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner
from drboard_assembler import AssemblyError, assemble, limits
from drboard_assembler import training as training_module
from drboard_assembler.record import CurvePoint, TrainingSummary
from drboard_cli.main import cli

EXAMPLES = Path(__file__).parents[2] / "examples"
CONSOLE = "speedy-ppo-console"
EVALUATION = "metrics/evaluation/evaluation-20210412113020-cEQMKFcxiXMeyUPoyZbNEb.json"
TRAINING = "metrics/training/training-20210412091503-l2M69i7WdDqgNmO6SfsyNV.json"
TRAINING_PARAMS = "training_params_e93304bf-ec65-4077-ad5d-3271471be40c.yaml"


def copy_example(tmp_path: Path) -> Path:
    run = tmp_path / CONSOLE
    shutil.copytree(EXAMPLES / CONSOLE, run)
    return run


def non_utf8(folder: Path, name: bytes) -> Path:
    return Path(os.fsdecode(os.path.join(os.fsencode(folder), name)))


def rewrite_training(run: Path, change: object) -> None:
    path = run / TRAINING
    data = json.loads(path.read_text())
    change(data["metrics"])  # type: ignore[operator]
    path.write_text(json.dumps(data))


def test_example_paths_used_here_exist() -> None:
    for name in (EVALUATION, TRAINING, TRAINING_PARAMS):
        assert (EXAMPLES / CONSOLE / name).is_file(), name


# ------------------------------------------------------------------ names that are not UTF-8

def test_a_metrics_file_named_in_latin_1_is_read_and_shown_escaped(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    target = non_utf8(run / "metrics" / "evaluation", b"course-\xe9t\xe9.json")
    (run / EVALUATION).rename(target)
    record = assemble(run)
    assert record.evaluations[0].source == "metrics/evaluation/course-\\xe9t\\xe9.json"
    assert record.model_dump_json()  # nothing in the record that JSON cannot hold


def test_a_broken_file_with_a_name_that_is_not_utf8_is_one_line_naming_it(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    non_utf8(run / "metrics" / "evaluation", b"bad-\xff\n.json").write_text("{")
    with pytest.raises(AssemblyError) as caught:
        assemble(run)
    message = str(caught.value)
    assert "metrics/evaluation/bad-\\xff\\n.json: not valid JSON" in message
    assert "\n" not in message
    result = CliRunner().invoke(cli, ["assemble", str(run)])
    assert result.exit_code == 2 and result.output.startswith("error: ")
    assert "bad-\\xff\\n.json" in result.output


def test_a_run_folder_whose_own_name_is_not_utf8(tmp_path: Path) -> None:
    run = non_utf8(tmp_path, b"mod\xe8le")
    shutil.copytree(EXAMPLES / CONSOLE, run)
    (run / EVALUATION).write_text("[")
    with pytest.raises(AssemblyError) as caught:
        assemble(run)
    assert str(caught.value).startswith(f"{tmp_path}/mod\\xe8le: {EVALUATION}: ")


# ------------------------------------------------------------------ training timestamps

def test_training_timestamps_spread_over_a_billion_seconds_are_bounded(tmp_path: Path) -> None:
    run = copy_example(tmp_path)

    def spread(entries: list[dict[str, float]]) -> None:
        last = entries[-1]
        last["start_time"] = 1e12
        last["metric_time"] = 1e12 + last["elapsed_time_in_milliseconds"]

    rewrite_training(run, spread)
    training = assemble(run).training
    assert training is not None and training.training_time_s == limits.MAX_TRAINING_S


def test_a_metric_time_that_disagrees_with_its_elapsed_time_is_left_out(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    before = assemble(run).training
    rewrite_training(run, lambda entries: entries[-1].update(metric_time=1e10))
    after = assemble(run).training
    assert before is not None and after is not None
    assert after.training_time_s < before.training_time_s + 60  # not a 116-day training


def test_a_training_track_name_past_the_bound_is_unknown(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    params = run / TRAINING_PARAMS
    params.write_text(params.read_text().replace('WORLD_NAME: "reInvent2019_track"',
                                                 f'WORLD_NAME: "{"x" * 65}"'))
    record = assemble(run)
    assert record.training is not None and record.training.track is None
    assert record.track == "reInvent2019_track"  # the evaluation's, unchanged


# ------------------------------------------------------------------ long trainings

def test_a_training_of_over_a_million_episodes_fits_the_record() -> None:
    summary = TrainingSummary(track=None, episodes=1_050_000, training_time_s=5.67e6, best_reward=61.5,
                              mean_reward=37.0, best_completion_pct=100, mean_completion_pct=50,
                              completed_laps=10_396,
                              curve=[CurvePoint(episode=1_050_000, reward=37.0, completion_pct=50.0)])
    assert TrainingSummary.model_validate_json(summary.model_dump_json()) == summary


@pytest.mark.parametrize("batched_from", [0, 10**9])
def test_too_many_training_entries_is_one_clean_message(monkeypatch: pytest.MonkeyPatch,
                                                        batched_from: int) -> None:
    monkeypatch.setattr(limits, "MAX_TRAINING_ENTRIES", 100)
    monkeypatch.setattr(training_module, "BATCHED_FROM_BYTES", batched_from)
    monkeypatch.setattr(training_module, "BATCH_BYTES", 500)
    with pytest.raises(AssemblyError) as caught:
        assemble(EXAMPLES / CONSOLE)
    assert str(caught.value).endswith(f"{TRAINING}: metrics: the training metrics hold over 100 entries, "
                                      "past any training's")


def test_a_large_training_file_whose_batches_do_not_read_is_read_whole(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A valid document the batches cannot cut (an array after the entries) is read as a whole,
    once: its episodes are not counted twice."""
    run = copy_example(tmp_path)
    path = run / TRAINING
    data = json.loads(path.read_text())
    episodes = sum(1 for entry in data["metrics"] if entry["phase"] == "training")
    path.write_text(json.dumps({"metrics": data["metrics"], "workers": [1, 2]}))
    monkeypatch.setattr(training_module, "BATCHED_FROM_BYTES", 0)
    monkeypatch.setattr(training_module, "BATCH_BYTES", 500)
    training = assemble(run).training
    assert training is not None and training.episodes == episodes


def test_a_large_training_file_read_in_batches_gives_the_same_summary(
        monkeypatch: pytest.MonkeyPatch) -> None:
    whole = assemble(EXAMPLES / CONSOLE).training
    monkeypatch.setattr(training_module, "BATCHED_FROM_BYTES", 0)
    monkeypatch.setattr(training_module, "BATCH_BYTES", 700)
    batched = assemble(EXAMPLES / CONSOLE).training
    assert batched == whole


def test_a_bad_entry_deep_in_a_batched_file_is_named_by_its_index(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    run = copy_example(tmp_path)
    rewrite_training(run, lambda entries: entries[23].update(completion_percentage=400))
    monkeypatch.setattr(training_module, "BATCHED_FROM_BYTES", 0)
    monkeypatch.setattr(training_module, "BATCH_BYTES", 500)
    with pytest.raises(AssemblyError) as caught:
        assemble(run)
    assert str(caught.value).endswith(f"{TRAINING}: metrics[23].completion_percentage: "
                                      "Input should be less than or equal to 100")


def test_a_record_of_many_runs_keeps_within_16_kib_with_a_coarser_training_curve(tmp_path: Path) -> None:
    from tests import layoutkit as kit
    from tests.downloadkit import console_download, console_params

    run = console_download(tmp_path / "pitstop-v3")
    for race in range(4):  # leaderboard races, logged without their metrics files
        laps = kit.Evaluation(tuple(kit.LapSpec(10.0 + race + lap / 10) for lap in range(3)))
        kit.write(run / "logs" / "leaderboard" / f"leaderboard-2024050{race}-robomaker.log",
                  kit.evaluation_log(console_params(METRICS_S3_OBJECT_KEY=f"lb/race-{race}.json"), laps))
    record = assemble(run)
    assert len(record.evaluations) == 5
    assert len(record.model_dump_json()) <= 16 * 1024
    assert record.training is not None and record.training.episodes == 188
    assert limits.MIN_CURVE_POINTS <= len(record.training.curve) < 188
