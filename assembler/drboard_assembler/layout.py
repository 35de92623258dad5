"""Step 1, find the files: the inputs of a run folder, whatever layout wrote it.

Files are known by their names first (``model_metadata.json``, ``eval_params_<uuid>.yaml``,
``metrics/evaluation/*.json``, ``*.log``, ...), then, for a file no name describes, by what it
holds: racers rename metrics files and save logs as ``*.txt`` or with no extension at all, so the
head of such a file is read to tell a job log, an evaluation or a training metrics file.
"""

from __future__ import annotations

import os
import re
import stat
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from . import limits
from .errors import AssemblyError, printable
from .record import SourceLayout

_PARAMS = re.compile(r"^(training_params|evaluation_params|eval_params)([_-][\w.-]+)?\.ya?ml$",
                     re.IGNORECASE)
_TRAINING = re.compile(r"^(TrainingMetrics.*|training-.+|.+-training-.+|training(_metrics)?)\.json$",
                       re.IGNORECASE)
_EVALUATION = re.compile(
    r"^(EvaluationMetrics.*|EvalMetrics.*|evaluation-.+|.+-(evaluation|submission)-.+"
    r"|evaluation(_metrics)?)\.json$",
    re.IGNORECASE)
#: Files whose kind no content could change: media, models, code, archives, sim-traces.
_NEVER_SNIFFED = {".py", ".mp4", ".png", ".jpg", ".jpeg", ".gif", ".pb", ".onnx", ".h5", ".index",
                  ".meta", ".gz", ".tgz", ".tar", ".zip", ".yaml", ".yml", ".md", ".ckpt", ".npy"}
_LOG_MARKERS = (b"SIM_TRACE_LOG", b"Action space from file", b"Using the following hyper-parameters",
                b"WORLD_NAME", b"Training>", b"@message", b"simapp_version", b"sagemaker")
_METRICS = re.compile(rb'"metrics"\s*:\s*\[\s*\{(?P<entry>[^{}]{0,2000})\}', re.DOTALL)
_TRAINING_KEYS = (b'"phase"', b'"reward_score"', b'"episode"')
_EVALUATION_KEYS = (b'"trial"', b'"off_track_count"', b'"crash_count"', b'"elapsed_time_in_milliseconds"')


@dataclass
class RunFiles:
    root: Path
    model_metadata: list[Path] = field(default_factory=list)
    hyperparameters: list[Path] = field(default_factory=list)
    params: list[Path] = field(default_factory=list)
    training_metrics: list[Path] = field(default_factory=list)
    evaluation_metrics: list[Path] = field(default_factory=list)
    logs: list[Path] = field(default_factory=list)

    def name(self, path: Path) -> str:
        """The path as the racer sees it: relative to the run folder, printable (a name that is
        not UTF-8 is shown with its bytes escaped)."""
        return printable(path.relative_to(self.root).as_posix())

    @property
    def layout(self) -> SourceLayout:
        names = [p.name for p in self.training_metrics + self.evaluation_metrics]
        if any("deepracerindy" in n for n in names):
            return SourceLayout.DROA
        if any(n.startswith(("TrainingMetrics", "EvaluationMetrics")) for n in names):
            return SourceLayout.DRFC
        if any(re.match(r"^(training|evaluation)-\d{14}-", n) for n in names) or any(
            re.match(r"^(training_params|eval_params)_[0-9a-f-]{36}\.ya?ml$", p.name)
            for p in self.params
        ):
            return SourceLayout.CONSOLE
        return SourceLayout.PLAIN

    def top_folder(self, path: Path) -> str | None:
        """The folder of the run folder's top level the file is in (None: at the top)."""
        parts = path.relative_to(self.root).parts
        return parts[0] if len(parts) > 1 else None


def find_run_files(root: Path) -> RunFiles:
    if not root.is_dir():
        raise AssemblyError(str(root), "", "is not a folder or a .tar.gz archive")
    found = RunFiles(root=root)
    sniffed = 0
    for path in _files_of(root):
        if not _classify_by_name(found, path) and _sniffable(path) and sniffed < limits.MAX_SNIFFED_FILES:
            sniffed += 1
            _classify_by_content(found, path)
    return found


def _files_of(root: Path) -> Iterator[Path]:
    """The run folder's regular files, in name order, leaving out hidden ones."""
    seen = 0
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for filename in sorted(files):
            seen += 1
            if seen > limits.MAX_FILES_SCANNED:
                raise AssemblyError(str(root), "", f"holds more than {limits.MAX_FILES_SCANNED} files")
            path = Path(folder, filename)
            if not filename.startswith(".") and _regular_file_inside(path, root):
                yield path


def evaluation_files(root: Path) -> list[str]:
    """The run folder's evaluation metrics files, relative to it (``metrics/evaluation/x.json``),
    in name order: each one is an evaluation run, which ``assemble(root, evaluation=name)``
    makes a record of on its own."""
    files = find_run_files(root)
    return sorted(files.name(path) for path in files.evaluation_metrics)


def _regular_file_inside(path: Path, root: Path) -> bool:
    """Whether the name is a regular file of the run folder: a link is followed only within
    it, and FIFOs, sockets, devices and links that lead nowhere (or round in a loop) are
    passed over."""
    try:
        if path.is_symlink() and not path.resolve(strict=True).is_relative_to(root.resolve()):
            return False
        return stat.S_ISREG(path.stat().st_mode)
    except (OSError, RuntimeError):  # a dangling link; a link loop (RuntimeError before 3.13)
        return False


def _classify_by_name(found: RunFiles, path: Path) -> bool:
    name = path.name
    if name.lower().endswith(".log"):
        found.logs.append(path)
    elif name == "model_metadata.json":
        found.model_metadata.append(path)
    elif name == "hyperparameters.json":
        found.hyperparameters.append(path)
    elif _PARAMS.match(name):
        found.params.append(path)
    elif _is_metrics_name(path, _EVALUATION, ("evaluation", "submission")):
        found.evaluation_metrics.append(path)
    elif _is_metrics_name(path, _TRAINING, ("training",)):
        found.training_metrics.append(path)
    else:
        return False
    return True


def _is_metrics_name(path: Path, pattern: re.Pattern[str], folders: tuple[str, ...]) -> bool:
    if not path.name.lower().endswith(".json"):
        return False
    under_metrics = path.parent.parent.name.lower() == "metrics"
    return bool(pattern.match(path.name)) or (path.parent.name.lower() in folders and under_metrics)


def _sniffable(path: Path) -> bool:
    in_simtrace = any(part.lower().endswith(("simtrace", "sim-trace")) for part in path.parent.parts)
    return path.suffix.lower() not in _NEVER_SNIFFED and not in_simtrace


def _classify_by_content(found: RunFiles, path: Path) -> None:
    head = _head(path)
    if head is None or b"\x00" in head:
        return
    if (kind := _metrics_kind(head)) is not None:
        (found.evaluation_metrics if kind == "evaluation" else found.training_metrics).append(path)
    elif any(marker in head for marker in _LOG_MARKERS):
        found.logs.append(path)


def _head(path: Path) -> bytes | None:
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return None
    with os.fdopen(descriptor, "rb") as handle:
        try:
            return handle.read(limits.SNIFF_BYTES)
        except OSError:
            return None


def _metrics_kind(head: bytes) -> str | None:
    """"training" or "evaluation" for the head of a metrics file, by its first entry's keys."""
    if not head.lstrip().startswith(b"{"):
        return None
    match = _METRICS.search(head)
    if match is None:
        return None
    entry = match["entry"]
    if any(key in entry for key in _TRAINING_KEYS):
        return "training"
    if any(key in entry for key in _EVALUATION_KEYS):
        return "evaluation"
    return None


def shallowest(paths: list[Path], root: Path) -> Path | None:
    """The file nearest the run folder's top (a model/ copy loses to the top-level one)."""
    if not paths:
        return None
    return min(paths, key=lambda p: (len(p.relative_to(root).parts), p.as_posix()))
