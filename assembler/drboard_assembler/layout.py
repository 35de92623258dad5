"""Find the five inputs in a run folder, whatever layout wrote it."""

from __future__ import annotations

import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path

from . import limits
from .errors import AssemblyError
from .record import SourceLayout

_PARAMS = re.compile(r"^(training_params|evaluation_params|eval_params)([_-][\w.-]+)?\.ya?ml$",
                     re.IGNORECASE)
_TRAINING = re.compile(r"^(TrainingMetrics.*|training-.+|.+-training-.+|training(_metrics)?)\.json$",
                       re.IGNORECASE)
_EVALUATION = re.compile(
    r"^(EvaluationMetrics.*|EvalMetrics.*|evaluation-.+|.+-(evaluation|submission)-.+"
    r"|evaluation(_metrics)?)\.json$",
    re.IGNORECASE)


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
        """The path as the racer sees it: relative to the run folder."""
        return path.relative_to(self.root).as_posix()

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


def find_run_files(root: Path) -> RunFiles:
    if not root.is_dir():
        raise AssemblyError(str(root), "", "is not a folder or a .tar.gz archive")
    found = RunFiles(root=root)
    seen = 0
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for filename in sorted(files):
            seen += 1
            if seen > limits.MAX_FILES_SCANNED:
                raise AssemblyError(str(root), "", f"holds more than {limits.MAX_FILES_SCANNED} files")
            path = Path(folder, filename)
            if _regular_file_inside(path, root):
                _classify(found, path)
    return found


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


def _classify(found: RunFiles, path: Path) -> None:
    name = path.name
    parent = path.parent.name.lower()
    under_metrics = path.parent.parent.name.lower() == "metrics"
    if name.lower().endswith(".log"):
        found.logs.append(path)
    elif name == "model_metadata.json":
        found.model_metadata.append(path)
    elif name == "hyperparameters.json":
        found.hyperparameters.append(path)
    elif _PARAMS.match(name):
        found.params.append(path)
    elif name.lower().endswith(".json") and (
        _EVALUATION.match(name) or (parent in ("evaluation", "submission") and under_metrics)
    ):
        found.evaluation_metrics.append(path)
    elif name.lower().endswith(".json") and (
        _TRAINING.match(name) or (parent == "training" and under_metrics)
    ):
        found.training_metrics.append(path)


def shallowest(paths: list[Path], root: Path) -> Path | None:
    """The file nearest the run folder's top (a model/ copy loses to the top-level one)."""
    if not paths:
        return None
    return min(paths, key=lambda p: (len(p.relative_to(root).parts), p.as_posix()))
