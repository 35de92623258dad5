"""Seeded mutations of the example runs, for fuzzing the assembler.

``mutate(seed, into)`` writes one run into ``into`` (an example run, or a producer's download
built by tests/downloadkit.py: console with logs, DeepRacer-for-Cloud, DeepRacer on AWS, three
models in a folder) and breaks it in one to three ways drawn from the seed: flipped, cut or
inserted bytes; a JSON or YAML value swapped for a hostile one (NaN, huge or negative numbers,
5,000-digit integers, deep nesting, YAML aliases and tags); special files (FIFOs, symbolic-link
loops, links out of the folder); a file removed, emptied, duplicated, renamed (to a name that is
not UTF-8, holds control characters, is 255 bytes long, or loses or changes its extension),
re-encoded (UTF-16, Latin-1, a byte-order mark, CRLF) or grown past its bound; training metrics
with timestamps spread over a billion seconds, nonsense end times, huge episode numbers or
thousands of entries; a job log added, its lines cut or garbled; or the run packed as a
``.tar.gz`` that is then damaged.
The same seed always gives the same case. Used by tests/unit/test_fuzz_assembler.py (a small
budget) and bench/fuzz_assembler.py (thousands of cases, with time and memory bounds).
"""

from __future__ import annotations

import contextlib
import json
import os
import random
import shutil
import tarfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from tests import downloadkit, logkit

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

HOSTILE_VALUES: list[Any] = [
    float("nan"), float("inf"), -float("inf"), 1e308, -1e308, -1, 0, 10**30, 2**63, "", None,
    True, [], {}, "x" * 100_000, "\u202eevil\u200b", [[[[[[[[[[[[[[[[[[[[1]]]]]]]]]]]]]]]]]]]],
    {"nested": {"deeper": {"and": {"deeper": [1, 2, 3]}}}}, 3.5, "3", "NaN", "1e999",
]

HOSTILE_YAML = [
    'a: &a ["x","x","x","x","x","x","x","x"]\nb: &b [*a,*a,*a,*a,*a,*a,*a,*a]\n'
    "c: &c [*b,*b,*b,*b,*b,*b,*b,*b]\nd: [*c,*c,*c,*c,*c,*c,*c,*c]\n",
    "WORLD_NAME: " + "[" * 3000 + "]" * 3000 + "\n",
    "".join(" " * depth + "- \n" for depth in range(100)),
    "NUMBER_OF_TRIALS: " + "9" * 5000 + "\n",
    "WORLD_NAME: !!python/object/apply:os.system ['true']\n",
    "WORLD_NAME: !!binary aGVsbG8=\n",
    "RACER_NAME: [1, 2]\nWORLD_NAME: {a: b}\n",
    "- just\n- a\n- list\n",
    "WORLD_NAME: .nan\nNUMBER_OF_TRIALS: .inf\n",
    "\t\x00\xff",
    "WORLD_NAME: reInvent2019_track\nWORLD_NAME: Oval_track\n",
    "RACE_TYPE: HEAD_TO_BOT\nNUMBER_OF_BOT_CARS: -5\n",
]


def example_runs() -> list[Path]:
    return sorted(p for p in EXAMPLES.iterdir() if p.is_dir())


#: The producers' downloads the fuzzer also starts from, by the folder name each is written to.
DOWNLOADS: dict[str, Callable[[Path], Path]] = {
    "pitstop-console-with-logs": downloadkit.console_download,
    "fastcar-drfc": lambda folder: downloadkit.drfc_folder(folder, 38043),
    "droa-evaluation": downloadkit.droa_evaluation_download,
    "droa-solution": lambda folder: downloadkit.droa_solution_download(
        folder, downloadkit.kit.hyperparameters()),
    "three-models": downloadkit.three_models,
}


def mutate(seed: int, into: Path) -> Path:
    """Write case ``seed`` under ``into`` and return the path to assemble."""
    rng = random.Random(seed)
    source = rng.choice([*example_runs(), *DOWNLOADS])
    if isinstance(source, Path):
        run = into / source.name
        shutil.copytree(source, run)
    else:
        run = DOWNLOADS[source](into / source)
    for _ in range(rng.choice((1, 1, 2, 3))):
        with contextlib.suppress(OSError):  # a name grown past the file system's bound
            rng.choice(FOLDER_MUTATIONS)(rng, run)
    if rng.random() < 0.2:
        return _archive(rng, run, into)
    return run


def _files(run: Path) -> list[Path]:
    return sorted(p for p in run.rglob("*") if p.is_file() and not p.is_symlink())


#: A file grown past this (a sparse file past every bound) is not edited again: it stays as big.
EDITED_BYTES = 16 * 1024 * 1024


def _pick(rng: random.Random, run: Path, suffixes: tuple[str, ...] = ()) -> Path | None:
    files = [p for p in _files(run) if (not suffixes or p.suffix in suffixes)
             and p.stat().st_size <= EDITED_BYTES]
    return rng.choice(files) if files else None


def flip_bytes(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run)) is None:
        return
    data = bytearray(path.read_bytes())
    for _ in range(rng.randint(1, 16)):
        if data:
            data[rng.randrange(len(data))] = rng.randrange(256)
    path.write_bytes(bytes(data))


def cut_bytes(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run)) is None:
        return
    data = path.read_bytes()
    path.write_bytes(data[: rng.randint(0, len(data))])


def insert_bytes(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run)) is None:
        return
    data = path.read_bytes()
    at = rng.randint(0, len(data))
    junk = rng.choice([b"\x00", b"{", b"]", b"\xff\xfe", b"\n\t- ", b"&a ", b"*a", b"NaN", b"9" * 5000])
    path.write_bytes(data[:at] + junk + data[at:])


def swap_json_value(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run, (".json",))) is None:
        return
    try:
        data = json.loads(path.read_bytes())
    except ValueError:
        return
    _replace_leaf(rng, data, rng.choice(HOSTILE_VALUES))
    path.write_text(json.dumps(data))


def _replace_leaf(rng: random.Random, data: Any, value: Any) -> None:
    for _ in range(8):
        if isinstance(data, dict) and data:
            key = rng.choice(sorted(data))
            if not isinstance(data[key], (dict, list)) or rng.random() < 0.2:
                if rng.random() < 0.15:
                    del data[key]
                else:
                    data[key] = value
                return
            data = data[key]
        elif isinstance(data, list) and data:
            index = rng.randrange(len(data))
            if not isinstance(data[index], (dict, list)) or rng.random() < 0.2:
                data[index] = value
                return
            data = data[index]
        else:
            return


def big_json_number(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run, (".json",))) is None:
        return
    text = path.read_text(errors="replace")
    digits = [i for i, ch in enumerate(text) if ch.isdigit()]
    if digits:
        at = rng.choice(digits)
        path.write_text(text[:at] + "9" * rng.choice((400, 5000)) + text[at:])


def swap_yaml(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run, (".yaml", ".yml"))) is None:
        return
    hostile = rng.choice(HOSTILE_YAML)
    if rng.random() < 0.5:
        path.write_text(hostile)
    else:
        path.write_text(path.read_text(errors="replace") + hostile)


def edit_yaml_value(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run, (".yaml", ".yml"))) is None:
        return
    lines = path.read_text(errors="replace").splitlines()
    if not lines:
        return
    index = rng.randrange(len(lines))
    key = lines[index].split(":", 1)[0]
    value = rng.choice(['""', "-1", "1e999", "null", "[]", '"\u202eabc"', "9" * 30,
                        '"reInvent2019_track_oa"', '"OBJECT_AVOIDANCE"', '"HEAD_TO_BOT"', "~",
                        '"' + "x" * 80 + '"', '"5.0e3"', "nan", '"caf\xe9"'])
    lines[index] = f"{key}: {value}"
    path.write_text("\n".join(lines) + "\n")


def special_file(rng: random.Random, run: Path) -> None:
    folder = rng.choice([run, *(p for p in run.rglob("*") if p.is_dir() and not p.is_symlink())])
    name = rng.choice(["model_metadata.json", "evaluation-20990101000000-x.json", "x.yaml",
                       "hyperparameters.json", "loop"])
    target = folder / name
    if target.exists() or target.is_symlink():
        if target.is_dir():
            return
        target.unlink()
    kind = rng.choice(["fifo", "loop", "dangling", "outside", "dir"])
    if kind == "fifo" and hasattr(os, "mkfifo"):
        os.mkfifo(target)
    elif kind == "loop":
        target.symlink_to(target)
    elif kind == "dangling":
        target.symlink_to(run / "no-such-file")
    elif kind == "outside":
        target.symlink_to("/etc/hostname")
    else:
        target.mkdir()


def remove_or_empty(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run)) is None:
        return
    if rng.random() < 0.5:
        path.unlink()
    else:
        path.write_bytes(b"")


def duplicate_file(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run)) is None:
        return
    copy = path.with_name(f"copy-{path.name}")
    shutil.copy(path, copy)


def oversize_file(rng: random.Random, run: Path) -> None:
    if (path := _pick(rng, run, (".json", ".yaml"))) is None:
        return
    with path.open("r+b") as file:  # sparse: past every bound without using the disk
        file.truncate(rng.choice((2 * 1024**2, 300 * 1024**2)))


def add_log(rng: random.Random, run: Path) -> None:
    """A job log beside (or instead of) the run's files, its lines perhaps damaged."""
    laps = [(rng.uniform(0.01, 40), rng.choice(["lap_complete", "off_track", "crashed", "x"]))
            for _ in range(rng.randint(0, 4))]
    params = logkit.job_params(rng.choice(["EVALUATION", "TRAINING", "SUBMISSION", ""]),
                               world=rng.choice(["reInvent2019_track", "Spain_track", "nowhere", ""]),
                               racer=rng.choice(["Logged", "", "\u202eevil"]))
    lines = logkit.simulation_log(params, laps, prefix=rng.choice(["", logkit.DROA_PREFIX]),
                                  actions=rng.choice([None, [], {"speed": 1}, "junk"])).splitlines()
    for _ in range(rng.randint(0, 6)):
        if lines:
            index = rng.randrange(len(lines))
            lines[index] = lines[index][: rng.randint(0, len(lines[index]))] + rng.choice(
                ["", ",nan,", "[" * 50, "'", "9" * 400])
    if rng.random() < 0.4:
        for name in ("model_metadata.json", "model"):
            target = run / name
            if target.is_dir():
                shutil.rmtree(target)
            elif target.exists():
                target.unlink()
    logkit.write(run / "logs" / "evaluation" / "evaluation-20240501101010-Fz-robomaker.log",
                 "\n".join(lines) + "\n")


def rename_file(rng: random.Random, run: Path) -> None:
    """A file renamed as racers and their tools do, and as no tool should."""
    if (path := _pick(rng, run)) is None:
        return
    stem = path.stem
    name = rng.choice([
        os.fsencode(stem) + b"-\xff\xfe" + os.fsencode(path.suffix),  # not UTF-8
        os.fsencode(stem) + b"-caf\xe9" + os.fsencode(path.suffix),  # Latin-1
        os.fsencode(f"{stem}\n\t\x1b[31m{path.suffix}"),  # control characters
        os.fsencode(("x" * 250 + path.suffix)[-255:]),  # as long as a name can be
        os.fsencode(f"{stem}.txt"), os.fsencode(stem), os.fsencode(path.name.upper()),
        os.fsencode(f"{stem} (1){path.suffix}"), os.fsencode(f"renamed{path.suffix}"),
    ])
    with contextlib.suppress(OSError):
        path.rename(Path(os.fsdecode(os.path.join(os.fsencode(path.parent), name))))


def reencode_file(rng: random.Random, run: Path) -> None:
    """A text file saved again in another encoding, or with a byte-order mark or CRLF."""
    if (path := _pick(rng, run, (".json", ".yaml", ".log", ".txt"))) is None:
        return
    text = path.read_bytes().decode("utf-8", "replace")
    encoding = rng.choice(["utf-16", "utf-8-sig", "latin-1", "crlf", "cp1252"])
    if encoding == "crlf":
        path.write_bytes(text.replace("\n", "\r\n").encode())
    elif encoding in ("latin-1", "cp1252"):
        path.write_bytes((text + "  # café ñ").encode(encoding, "replace"))
    else:
        path.write_bytes(text.encode(encoding))


def training_metrics(rng: random.Random, run: Path) -> None:
    """Training metrics whose figures no training has: timestamps spread over 10^9 s, an end
    time of 10^10, episode numbers past any count, copies, thousands of entries."""
    files = [p for p in _files(run) if p.suffix == ".json" and "raining" in str(p.relative_to(run))
             and p.stat().st_size <= EDITED_BYTES]
    if not files:
        return
    path = rng.choice(files)
    try:
        data = json.loads(path.read_bytes())
        entries = data["metrics"]
        assert isinstance(entries, list) and entries and all(isinstance(e, dict) for e in entries)
    except (ValueError, KeyError, TypeError, AssertionError):
        return
    kind = rng.choice(["spread", "end", "episode", "copy", "many", "phase", "reward"])
    last = entries[-1]
    if kind == "spread":
        elapsed = last.get("elapsed_time_in_milliseconds", 0)
        last["start_time"], last["metric_time"] = 1e12, 1e12 + (elapsed if isinstance(elapsed, int) else 0)
    elif kind == "end":
        rng.choice(entries)["metric_time"] = rng.choice([1e10, 1e14, -1, 0])
    elif kind == "episode":
        rng.choice(entries)["episode"] = rng.choice([10**6 + 1, 10**8, 10**8 + 1, -5])
    elif kind == "copy":
        shutil.copy(path, path.with_name(f"copy-{path.name}"))
        return
    elif kind == "many":
        data["metrics"] = entries * (rng.randint(2000, 20000) // len(entries) + 1)
    elif kind == "phase":
        for entry in entries:
            entry["phase"] = rng.choice(["evaluation", "TRAINING", "", "x" * 40])
    else:
        rng.choice(entries)["reward_score"] = rng.choice([1e9, -1e9, 1e10])
    path.write_text(json.dumps(data))


FOLDER_MUTATIONS: list[Callable[[random.Random, Path], None]] = [
    flip_bytes, cut_bytes, insert_bytes, swap_json_value, swap_json_value, big_json_number,
    swap_yaml, edit_yaml_value, special_file, remove_or_empty, duplicate_file, oversize_file,
    add_log, add_log, rename_file, rename_file, reencode_file, training_metrics, training_metrics,
]


def _archive(rng: random.Random, run: Path, into: Path) -> Path:
    archive = into / f"{run.name}.tar.gz"
    with tarfile.open(archive, "w:gz") as tar:
        for path in sorted(run.rglob("*")):
            if path.is_symlink() or path.is_file() or path.is_dir():
                if not path.is_symlink() and path.is_file() and path.stat().st_size > 1024**2:
                    continue
                tar.add(path, arcname=str(path.relative_to(into)), recursive=False)
    shutil.rmtree(run)
    damage = rng.choice(["none", "cut", "flip"])
    data = bytearray(archive.read_bytes())
    if damage == "cut":
        data = data[: rng.randint(0, len(data))]
    elif damage == "flip" and data:
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] = rng.randrange(256)
    archive.write_bytes(bytes(data))
    return archive
