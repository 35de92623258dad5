"""Step 2, read the parameters and the logs; and the reader every step reads its files with,
which keeps the provenance of the files the record is built from."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

from . import limits
from .layout import RunFiles
from .logs import JobLog, read_log
from .params import RunParams, load_params
from .reading import read_bounded
from .record import SourceFile


@dataclass(frozen=True)
class Loaded:
    """A file's bytes as read, with the name the racer sees."""

    path: Path
    name: str
    data: bytes
    sha256: str


class Reader:
    """Reads the run folder's files within their bounds and remembers the ones used."""

    def __init__(self, files: RunFiles) -> None:
        self.files = files
        self.provenance: list[SourceFile] = []

    def load(self, path: Path, max_bytes: int) -> Loaded:
        name = self.files.name(path)
        data = read_bounded(path, name, max_bytes)
        return Loaded(path, name, data, hashlib.sha256(data).hexdigest())

    def use(self, role: str, loaded: Loaded) -> None:
        self.note(role, loaded.name, loaded.sha256, len(loaded.data))

    def use_log(self, log: JobLog) -> None:
        role = "training_log" if log.job == "training" else "simulation_log"
        self.note(role, log.name, log.sha256, log.size)

    def note(self, role: str, name: str, sha256: str, size: int) -> None:
        if any(source.path == name[: limits.MAX_TEXT_CHARS] for source in self.provenance):
            return
        self.provenance.append(SourceFile.model_validate({
            "role": role, "path": name[: limits.MAX_TEXT_CHARS], "sha256": sha256,
            "bytes": min(size, limits.MAX_TRAINING_FILE_BYTES),
        }))


@dataclass
class Inputs:
    """The run's parameters (its params files, and what its logs printed) and its logs."""

    params: list[RunParams]
    logs: list[JobLog]
    #: The params files as read, by name, for the provenance of the ones the record uses.
    loaded: dict[str, Loaded]

    @property
    def all_params(self) -> list[RunParams]:
        return self.params + [log.params for log in self.logs if log.params is not None]

    @property
    def evaluation_params(self) -> list[RunParams]:
        return [p for p in self.all_params if p.kind == "evaluation"]

    @property
    def training_params(self) -> list[RunParams]:
        return [p for p in self.all_params if p.kind == "training"]

    @property
    def evaluation_logs(self) -> list[JobLog]:
        """The logs of evaluation jobs that hold laps."""
        return [log for log in self.logs if log.is_evaluation and log.laps()]

    def params_file(self, name: str) -> RunParams | None:
        return next((p for p in self.params if p.name == name), None)


def read_inputs(files: RunFiles, reader: Reader) -> Inputs:
    params, loaded = [], {}
    for path in files.params:
        read = reader.load(path, limits.MAX_SMALL_FILE_BYTES)
        params.append(load_params(read.data, read.name))
        loaded[read.name] = read
    logs = [read_log(path, files.name(path)) for path in sorted(files.logs)[: limits.MAX_LOG_FILES]]
    return Inputs(params=params, logs=logs, loaded=loaded)


def use_params(reader: Reader, inputs: Inputs, used: list[RunParams]) -> None:
    """Note the params files (and the logs whose parameters) the record is built from."""
    for params in used:
        if (read := inputs.loaded.get(params.name)) is not None:
            reader.use(f"{params.kind}_params", read)
        elif (log := next((log for log in inputs.logs if log.params is params), None)) is not None:
            reader.use_log(log)
