"""Files no run folder should hold: each one skipped or refused with one clear error, quickly.

FIFOs, symbolic-link loops, YAML alias bombs, nesting and numbers past any real run's, corrupt
archives; and archives on Python versions whose tarfile lacks extraction filters.
"""

from __future__ import annotations

import gzip
import io
import os
import shutil
import tarfile
from pathlib import Path

import pytest
from drboard_assembler import AssemblyError, assemble, planned_trials

EXAMPLES = Path(__file__).parents[2] / "examples"
CONSOLE = "speedy-ppo-console"
EVALUATION = "metrics/evaluation/evaluation-20210412113020-cEQMKFcxiXMeyUPoyZbNEb.json"
EVAL_PARAMS = "eval_params_e3e2651f-2aed-4465-bd1b-a24f5978ac95.yaml"


def copy_example(tmp_path: Path) -> Path:
    run = tmp_path / CONSOLE
    shutil.copytree(EXAMPLES / CONSOLE, run)
    return run


def assembly_error(path: Path) -> str:
    with pytest.raises(AssemblyError) as caught:
        assemble(path)
    message = str(caught.value)
    if caught.value.given is not None:  # the path the racer gave comes first
        assert message.startswith(f"{path}: ")
        message = message.removeprefix(f"{path}: ")
    return message


def make_archive(tmp_path: Path, run: Path) -> Path:
    archive = tmp_path / f"{run.name}.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(run, arcname=run.name)
    return archive


# ------------------------------------------------------------------ special files

@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are a POSIX thing")
def test_a_fifo_beside_the_run_is_skipped(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    os.mkfifo(run / "metrics" / "evaluation" / "pipe.json")
    assert assemble(run).track == "reInvent2019_track"


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="FIFOs are a POSIX thing")
def test_a_fifo_in_place_of_the_model_metadata_is_not_read(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    (run / "model_metadata.json").unlink()
    os.mkfifo(run / "model_metadata.json")
    record = assemble(run)  # the design is unknown: nothing else in the folder describes it
    assert record.design.action_space is None and record.design.algorithm is None
    assert "model_metadata" not in {source.role for source in record.provenance}


def test_a_symlink_loop_in_the_folder_is_skipped(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    (run / "metrics" / "loop").symlink_to(run / "metrics" / "loop")
    (run / "metrics" / "evaluation" / "a.json").symlink_to(run / "metrics" / "evaluation" / "b.json")
    (run / "metrics" / "evaluation" / "b.json").symlink_to(run / "metrics" / "evaluation" / "a.json")
    (run / "metrics" / "evaluation" / "gone.json").symlink_to(tmp_path / "nowhere.json")
    assert assemble(run).track == "reInvent2019_track"


def test_a_symlink_out_of_the_folder_is_not_followed(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    outside = tmp_path / "outside.json"
    shutil.move(run / "model_metadata.json", outside)
    (run / "model_metadata.json").symlink_to(outside)
    record = assemble(run)
    assert record.design.action_space is None
    assert "model_metadata" not in {source.role for source in record.provenance}


# ------------------------------------------------------------------ YAML and JSON past any real run

def test_a_yaml_alias_bomb_is_refused_at_once(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    layers = ['a: &a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for level in range(1, 9):
        previous, name = chr(ord("a") + level - 1), chr(ord("a") + level)
        layers.append(f"{name}: &{name} [" + ",".join([f"*{previous}"] * 9) + "]")
    (run / EVAL_PARAMS).write_text("\n".join(layers) + "\n")
    message = assembly_error(run)
    assert message.startswith(f"{EVAL_PARAMS}: line 2: ")
    assert "aliases" in message


@pytest.mark.parametrize("text", [
    "WORLD_NAME: " + "[" * 5000 + "]" * 5000,
    "WORLD_NAME:\n" + "".join(" " * depth + "- \n" for depth in range(200)),
], ids=["flow", "block"])
def test_yaml_nested_past_the_bound_is_refused(tmp_path: Path, text: str) -> None:
    run = copy_example(tmp_path)
    (run / EVAL_PARAMS).write_text(text)
    message = assembly_error(run)
    assert message.startswith(f"{EVAL_PARAMS}: line ")
    assert "nested deeper than" in message


def test_a_5000_digit_number_in_yaml_is_refused(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    (run / EVAL_PARAMS).write_text("NUMBER_OF_TRIALS: " + "9" * 5000 + "\n")
    assert assembly_error(run).startswith(f"{EVAL_PARAMS}: ")


@pytest.mark.parametrize("file", ["model_metadata.json", "ip/hyperparameters.json", EVALUATION])
def test_a_5000_digit_number_in_json_is_refused(tmp_path: Path, file: str) -> None:
    run = copy_example(tmp_path)
    (run / file).write_text('{"x": ' + "9" * 5000 + "}")
    assert assembly_error(run).startswith(f"{file}: ")


def test_json_nested_past_the_stack_is_refused(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    (run / "model_metadata.json").write_text("[" * 100_000 + "]" * 100_000)
    assert assembly_error(run).startswith("model_metadata.json: ")


def test_a_huge_trial_count_in_the_params_plans_no_trials(tmp_path: Path) -> None:
    run = copy_example(tmp_path)
    params = run / EVAL_PARAMS
    huge = "NUMBER_OF_TRIALS: " + "9" * 2000
    params.write_text(params.read_text().replace('NUMBER_OF_TRIALS: "3"', huge))
    assert planned_trials(run, EVALUATION) is None


# ------------------------------------------------------------------ archives

def test_archives_unpack_without_tarfile_extraction_filters(tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    """Python 3.11.0 to 3.11.3 (Debian 12 has 3.11.2) have no ``filter=`` argument."""
    def old_extractall(*args: object, filter: object = None, **kwargs: object) -> None:
        if filter is not None:
            raise TypeError("extractall() got an unexpected keyword argument 'filter'")
        raise AssertionError("extraction must not rely on tarfile's own extractall")
    monkeypatch.setattr(tarfile.TarFile, "extractall", old_extractall)
    monkeypatch.delattr(tarfile, "data_filter", raising=False)
    archive = make_archive(tmp_path, EXAMPLES / CONSOLE)
    assert assemble(archive).racer == assemble(EXAMPLES / CONSOLE).racer


def test_unpacked_files_take_no_modes_from_the_archive(tmp_path: Path) -> None:
    run = copy_example(tmp_path / "src")
    (run / "model_metadata.json").chmod(0o4777)
    archive = make_archive(tmp_path, run)
    assert assemble(archive).track == "reInvent2019_track"


@pytest.mark.parametrize("cut", [0.3, 0.6, 0.95])
def test_a_truncated_archive_is_one_clear_error(tmp_path: Path, cut: float) -> None:
    archive = make_archive(tmp_path, EXAMPLES / CONSOLE)
    data = archive.read_bytes()
    archive.write_bytes(data[: int(len(data) * cut)])
    message = assembly_error(archive)
    assert message.startswith(("not a readable tar archive", "model_metadata.json: not found"))


def test_an_archive_with_corrupt_compressed_data_is_one_clear_error(tmp_path: Path) -> None:
    archive = make_archive(tmp_path, EXAMPLES / CONSOLE)
    data = bytearray(archive.read_bytes())
    for offset in range(len(data) // 2, len(data) // 2 + 64):
        data[offset] ^= 0x5A
    archive.write_bytes(bytes(data))
    assert assembly_error(archive).startswith(("not a readable tar archive", "model_metadata.json"))


def test_a_gzip_of_something_else_is_one_clear_error(tmp_path: Path) -> None:
    archive = tmp_path / "run.tar.gz"
    archive.write_bytes(gzip.compress(b"just some text, not a tar\n" * 100))
    assert assembly_error(archive).startswith("not a readable tar archive")


def test_an_archive_member_in_place_of_a_folder_is_one_clear_error(tmp_path: Path) -> None:
    archive = tmp_path / "clash.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        tar.add(EXAMPLES / CONSOLE, arcname=CONSOLE)
        info = tarfile.TarInfo(f"{CONSOLE}/metrics")
        info.size = 4
        tar.addfile(info, io.BytesIO(b"evil"))
    assert assembly_error(archive).startswith("cannot be unpacked")
