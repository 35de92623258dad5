"""Bad input: one clear AssemblyError naming the file and the field, and nothing written.

Each case copies an example run to tmp_path and breaks one thing.
"""

from __future__ import annotations

import io
import json
import shutil
import tarfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from drboard_assembler import AssemblyError, Overrides, Record, assemble, limits
from pydantic import ValidationError

EXAMPLES = Path(__file__).parents[2] / "examples"
CONSOLE = "speedy-ppo-console"
EVALUATION = "metrics/evaluation/evaluation-20210412113020-cEQMKFcxiXMeyUPoyZbNEb.json"
TRAINING = "metrics/training/training-20210412091503-l2M69i7WdDqgNmO6SfsyNV.json"
EVAL_PARAMS = "eval_params_e3e2651f-2aed-4465-bd1b-a24f5978ac95.yaml"


def copy_example(tmp_path: Path, name: str = CONSOLE) -> Path:
    run = tmp_path / name
    shutil.copytree(EXAMPLES / name, run)
    return run


def edit_json(path: Path, change: Callable[[Any], None]) -> None:
    data = json.loads(path.read_text())
    change(data)
    path.write_text(json.dumps(data))


def assembly_error(path: Path, overrides: Overrides | None = None) -> str:
    with pytest.raises(AssemblyError) as caught:
        assemble(path, overrides)
    message = str(caught.value)
    if caught.value.given is not None:  # the path the racer gave comes first
        assert message.startswith(f"{path}: ")
        message = message.removeprefix(f"{path}: ")
    return message


def test_example_paths_used_here_exist() -> None:
    for name in (EVALUATION, TRAINING, EVAL_PARAMS, "model_metadata.json",
                 "ip/hyperparameters.json"):
        assert (EXAMPLES / CONSOLE / name).is_file(), name


# ------------------------------------------------------------------ malformed and truncated JSON

@pytest.mark.parametrize(("file", "text", "where"), [
    ("model_metadata.json", '{"action_space": [}', "line 1 column 19"),
    ("ip/hyperparameters.json", '{"batch_size": 64,\n "lr": 0.0003,,\n}', "line 2 column 15"),
    (EVALUATION, '{"metrics": [{"trial": 1,, "x": 2}]}', "line 1 column 26"),
    (TRAINING, '{"metrics": [}', "line 1 column 14"),
])
def test_malformed_json(tmp_path: Path, file: str, text: str, where: str) -> None:
    run = copy_example(tmp_path)
    (run / file).write_text(text)
    message = assembly_error(run)
    assert message.startswith(f"{file}: ")
    assert where in message
    assert "not valid JSON" in message


@pytest.mark.parametrize("file", ["model_metadata.json", EVALUATION, TRAINING])
def test_truncated_json(tmp_path: Path, file: str) -> None:
    run = copy_example(tmp_path)
    data = (run / file).read_bytes()
    (run / file).write_bytes(data[: len(data) // 2])
    message = assembly_error(run)
    assert message.startswith(f"{file}: ")
    assert "not valid JSON" in message
    assert "line" in message


def test_missing_evaluation_metrics(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    shutil.rmtree(run / "metrics" / "evaluation")
    message = assembly_error(run)
    assert message.startswith("evaluation: there is no evaluation in it")


def test_missing_model_metadata_leaves_the_action_space_unknown(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    (run / "model_metadata.json").unlink()
    record = assemble(run)
    design = record.design
    assert (design.action_space, design.algorithm, design.sensors, design.metadata_version) == (
        None, None, None, None)
    assert design.sources is not None and design.sources.action_space is None
    assert design.hyperparameters is not None  # ip/hyperparameters.json is still there
    assert design.sources.hyperparameters == "ip/hyperparameters.json"


# ------------------------------------------------------------------ wrong types and values

def _set_speed(data: Any) -> None:
    data["action_space"][1]["speed"] = "fast"


def _set_range(data: Any) -> None:
    data["action_space"] = {"speed": {"low": 1.0, "high": "max"},
                            "steering_angle": {"low": -30, "high": 30}}


def _set_elapsed(data: Any) -> None:
    data["metrics"][1]["elapsed_time_in_milliseconds"] = "abc"


def _set_completion(data: Any) -> None:
    data["metrics"][2]["completion_percentage"] = 140


def _set_batch_size(data: Any) -> None:
    data["batch_size"] = "big"


def _set_reward(data: Any) -> None:
    data["metrics"][3]["reward_score"] = "high"


def _set_algorithm(data: Any) -> None:
    data["training_algorithm"] = "dqn"


@pytest.mark.parametrize(("file", "change", "field"), [
    ("model_metadata.json", _set_speed, "action_space.discrete[1].speed"),
    ("model_metadata.json", _set_range, "action_space.continuous.speed.high"),
    ("model_metadata.json", _set_algorithm, "training_algorithm"),
    (EVALUATION, _set_elapsed, "metrics[1].elapsed_time_in_milliseconds"),
    (EVALUATION, _set_completion, "metrics[2].completion_percentage"),
    ("ip/hyperparameters.json", _set_batch_size, "batch_size"),
    (TRAINING, _set_reward, "metrics[3].reward_score"),
], ids=["speed", "speed-range", "algorithm", "elapsed", "completion", "batch_size", "reward"])
def test_wrong_types(tmp_path: Path, file: str, change: Callable[[Any], None],
                     field: str) -> None:
    run = copy_example(tmp_path)
    edit_json(run / file, change)
    assert assembly_error(run).startswith(f"{file}: {field}: ")


def test_negative_lap_time(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    edit_json(run / EVALUATION,
              lambda d: d["metrics"][0].update(elapsed_time_in_milliseconds=-5))
    message = assembly_error(run)
    assert message.startswith(f"{EVALUATION}: metrics[0].elapsed_time_in_milliseconds: ")
    assert "greater than or equal to 0" in message


def test_lap_faster_than_physically_possible(tmp_path: Path) -> None:
    # 23.12 m at twice the model's 3.0 m/s top speed takes 3.85 s.
    run = copy_example(tmp_path)
    edit_json(run / EVALUATION,
              lambda d: d["metrics"][0].update(elapsed_time_in_milliseconds=2000))
    message = assembly_error(run)
    assert EVALUATION in message
    assert "lap 1 time 2000 ms is faster than possible" in message
    assert "reInvent2019_track" in message


# ------------------------------------------------------------------ YAML and sizes

def test_yaml_python_tag_is_refused_not_run(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    marker = tmp_path / "pwned"
    params = run / EVAL_PARAMS
    params.write_text(params.read_text() +
                      f'EXTRA: !!python/object/apply:os.system ["touch {marker}"]\n')
    message = assembly_error(run)
    assert message.startswith(f"{EVAL_PARAMS}: line ")
    assert "YAML tag not allowed" in message
    assert not marker.exists()


def test_yaml_that_is_not_a_mapping(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    (run / EVAL_PARAMS).write_text("- just\n- a list\n")
    assert assembly_error(run).startswith(f"{EVAL_PARAMS}: (top level): ")


@pytest.mark.parametrize("file", ["model_metadata.json", "ip/hyperparameters.json", EVAL_PARAMS])
def test_oversized_small_file(tmp_path: Path, file: str) -> None:
    run = copy_example(tmp_path)
    path = run / file
    padding = limits.MAX_SMALL_FILE_BYTES + 1 - path.stat().st_size
    path.write_text(path.read_text() + " " * padding)
    assert path.stat().st_size == limits.MAX_SMALL_FILE_BYTES + 1
    message = assembly_error(run)
    assert message.startswith(f"{file}: ")
    assert "limit" in message


# ------------------------------------------------------------------ hostile archives

def _archive(tmp_path: Path, *extra: tuple[tarfile.TarInfo, bytes | None]) -> Path:
    archive = tmp_path / "upload" / f"{CONSOLE}.tar.gz"
    archive.parent.mkdir()
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(EXAMPLES / CONSOLE, arcname=CONSOLE)
        for info, data in extra:
            tar.addfile(info, io.BytesIO(data) if data is not None else None)
    return archive


def _member(name: str, data: bytes | None = b"evil", **attributes: Any
            ) -> tuple[tarfile.TarInfo, bytes | None]:
    info = tarfile.TarInfo(name)
    info.size = len(data) if data is not None else 0
    for key, value in attributes.items():
        setattr(info, key, value)
    return info, data


@pytest.mark.parametrize(("member", "problem"), [
    (_member("/tmp/drboard-evil.json"), "absolute paths are not allowed"),
    (_member(f"{CONSOLE}/../../evil.json"), "'..' is not allowed"),
    (_member(f"{CONSOLE}/link.json", None, type=tarfile.SYMTYPE, linkname="/etc/passwd"),
     "links are not allowed"),
    (_member(f"{CONSOLE}/hard.json", None, type=tarfile.LNKTYPE,
             linkname=f"{CONSOLE}/model_metadata.json"), "links are not allowed"),
    (_member(f"{CONSOLE}/device", None, type=tarfile.CHRTYPE), "only files and folders"),
], ids=["absolute", "dotdot", "symlink", "hardlink", "device"])
def test_hostile_archive_member(tmp_path: Path, member: tuple[tarfile.TarInfo, bytes | None],
                                problem: str) -> None:
    archive = _archive(tmp_path, member)
    message = assembly_error(archive)
    assert message.startswith(f"{member[0].name}: ")
    assert problem in message
    assert not (tmp_path / "evil.json").exists()
    assert not Path("/tmp/drboard-evil.json").exists()


def test_archive_bigger_than_the_unpacked_bound(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(limits, "MAX_ARCHIVE_UNPACKED_BYTES", 4096)
    archive = _archive(tmp_path)
    message = assembly_error(archive)
    assert message.startswith(f"{CONSOLE}/")
    assert "unpacks to more than" in message


def test_file_that_is_not_an_archive(tmp_path: Path) -> None:
    archive = tmp_path / "run.tar.gz"
    archive.write_bytes(b"not a tar file")
    assert assembly_error(archive).startswith("not a readable tar archive")


# ------------------------------------------------------------------ tracks and racers

def test_unknown_track_lists_the_closest_matches(tmp_path: Path) -> None:
    message = assembly_error(EXAMPLES / CONSOLE, Overrides(track="reInvent2091"))
    assert message.startswith("--track: unknown track 'reInvent2091'; closest matches: ")
    assert "reInvent2019_track (Smile Speedway)" in message
    assert "--custom-track" in message


def test_unreadable_world_name_in_params(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    params = run / EVAL_PARAMS
    params.write_text(params.read_text().replace('"reInvent2019_track"', '"Smile / Speedway?"'))
    assert assembly_error(run).startswith(f"{EVAL_PARAMS}: WORLD_NAME: unknown track")


def test_ambiguous_track(tmp_path: Path) -> None:
    message = assembly_error(EXAMPLES / CONSOLE, Overrides(track="penbay"))
    assert message.startswith("--track: track 'penbay' is ambiguous")
    assert "penbay_open" in message and "penbay_pro" in message


def test_ambiguous_world_name_in_params(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    params = run / EVAL_PARAMS
    params.write_text(params.read_text().replace('"reInvent2019_track"', '"penbay"'))
    assert assembly_error(run).startswith(f"{EVAL_PARAMS}: WORLD_NAME: track 'penbay' is ambiguous")


def test_track_flag_naming_a_track_no_evaluation_ran_on(tmp_path: Path) -> None:
    message = assembly_error(EXAMPLES / CONSOLE, Overrides(track="Oval_track"))
    assert message.startswith("WORLD_NAME: no evaluation ran on Oval_track")
    assert "reInvent2019_track" in message and "--track" in message


def test_missing_racer_names_the_racer_flag(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    for params in run.glob("*_params_*.yaml"):
        lines = params.read_text().splitlines()
        params.write_text("\n".join(
            line for line in lines if not line.startswith(("RACER_NAME", "CAR_NAME"))) + "\n")
    message = assembly_error(run)
    assert message.startswith("RACER_NAME: ")
    assert "--racer" in message
    assert assemble(run, Overrides(racer="Speedy")).racer == "Speedy"


def test_evaluations_on_two_tracks_name_the_track_flag(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    oval_metrics = "evaluation-20210413100000-OvalOvalOvalOvalOvalOv.json"
    shutil.copy(run / EVALUATION, run / "metrics" / "evaluation" / oval_metrics)
    edit_json(run / "metrics" / "evaluation" / oval_metrics,
              lambda data: data["metrics"][0].update(elapsed_time_in_milliseconds=23456))
    text = (run / EVAL_PARAMS).read_text()
    (run / "eval_params_00000000-0000-4000-8000-000000000000.yaml").write_text(
        text.replace('WORLD_NAME: "reInvent2019_track"', 'WORLD_NAME: "Oval_track"')
        .replace(Path(EVALUATION).name, oval_metrics))
    message = assembly_error(run)
    assert message.startswith("evaluation parameters: WORLD_NAME: evaluations on several tracks")
    assert "Oval_track" in message and "reInvent2019_track" in message
    assert "--track" in message

    chosen = assemble(run, Overrides(track="Oval"))
    assert chosen.track == "Oval_track"
    assert [run.source for run in chosen.evaluations] == [f"metrics/evaluation/{oval_metrics}"]


def test_unknown_race_type(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    params = run / EVAL_PARAMS
    params.write_text(params.read_text().replace('"TIME_TRIAL"', '"DRAG_RACE"'))
    assert assembly_error(run).startswith(f"{EVAL_PARAMS}: RACE_TYPE: unknown race type")


# ------------------------------------------------------------------ tampered records

def _record_data() -> dict[str, Any]:
    record = assemble(EXAMPLES / CONSOLE)
    data: dict[str, Any] = json.loads(record.model_dump_json())
    return data


def test_tampered_lap_time_is_refused() -> None:
    data = _record_data()
    data["evaluations"][0]["laps"][1]["time_ms"] -= 1000
    with pytest.raises(ValidationError, match="best_lap_ms"):
        Record.model_validate_json(json.dumps(data))


def test_tampered_lap_time_with_matching_figures_still_fails_the_hash() -> None:
    data = _record_data()
    run = data["evaluations"][0]
    run["laps"][1]["time_ms"] -= 1000
    times = [lap["time_ms"] for lap in run["laps"]]
    run.update(best_lap_ms=min(times), average_lap_ms=round(sum(times) / len(times)),
               total_time_ms=sum(times))
    with pytest.raises(ValidationError, match="submission_id does not match"):
        Record.model_validate_json(json.dumps(data))


def test_tampered_submission_id_is_refused() -> None:
    data = _record_data()
    data["submission_id"] = "f" * 64
    with pytest.raises(ValidationError, match="submission_id does not match"):
        Record.model_validate_json(json.dumps(data))
