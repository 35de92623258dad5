"""The simulation (RoboMaker / simapp) and training (SageMaker) logs of a run: what the job
printed about itself.

Console, DeepRacer on AWS and DeepRacer-for-Cloud jobs all run the same simulation application,
which prints the job's parameters as a Python dict, ``Action space from file: [...]``, a
``Sensor list [...], network ..., training_algorithm ..., action_space_type ...`` line, the
hyperparameters as a JSON block after ``Using the following hyper-parameters``, and one
``SIM_TRACE_LOG:`` line per step. DeepRacer on AWS prefixes each line with the names of the
processes it went through (``[download_params_and_roslaunch_agent.py-1] ``).
"""

from __future__ import annotations

import ast
import hashlib
import json
import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import limits
from .errors import AssemblyError
from .params import RunParams, params_from_values
from .record import Lap

_PREFIX = re.compile(r"^(?:\[[\w.:-]+\] )+")
_SENSORS = re.compile(r"Sensor list (\[[^\]]*\]), network (\S+), simapp_version (\S+), "
                      r"training_algorithm (\S+), action_space_type (\w+)")
_ACTION_SPACE = "Action space from file: "
_HYPERPARAMETERS = "Using the following hyper-parameters"
_TRACE = "SIM_TRACE_LOG:"
# SIM_TRACE_LOG columns: episode, step, x, y, heading, steering, speed, action, reward, done,
# all_wheels_on_track, progress, closest_waypoint, track_len, tstamp, episode_status, ...
_EPISODE, _DONE, _PROGRESS, _TSTAMP, _STATUS = 0, 9, 11, 14, 15
_STATUSES = {"lap_complete": "Lap complete", "off_track": "Off track", "crashed": "Crashed",
             "reversed": "Reversed", "immobilized": "Immobilized", "time_up": "Time up"}


@dataclass
class _Episode:
    """One episode's steps, summed up as they are read (a long log has millions of steps)."""

    first: float
    last: float
    steps: int = 1
    status: str = ""
    end: tuple[float, float, str] | None = None  # tstamp, progress, status of the final step
    spells: dict[str, int] = field(default_factory=dict)

    def add(self, tstamp: float, progress: float, status: str, done: bool) -> None:
        if self.end is not None:
            return
        if status != self.status:
            self.spells[status] = self.spells.get(status, 0) + 1
            self.status = status
        self.last, self.steps = tstamp, self.steps + 1
        if done:
            self.end = (tstamp, progress, status)


@dataclass
class JobLog:
    """What one log file says about its job; each part None (or empty) when it does not say."""

    name: str
    sha256: str
    size: int
    params: RunParams | None = None
    action_space: Any = None
    sensors: list[str] | None = None
    network: str | None = None
    simapp_version: str | None = None
    algorithm: str | None = None
    action_space_type: str | None = None
    hyperparameters: dict[str, Any] | None = None
    episodes: dict[int, _Episode] = field(default_factory=dict)

    @property
    def is_evaluation(self) -> bool:
        return self.params is not None and self.params.kind == "evaluation"

    def metadata(self) -> bytes | None:
        """A model_metadata.json of what the log printed, when it printed the action space."""
        if self.action_space is None:
            return None
        return json.dumps({
            "action_space": self.action_space, "action_space_type": self.action_space_type,
            "training_algorithm": self.algorithm or "clipped_ppo", "sensor": self.sensors or [],
            "neural_network": self.network, "version": self.simapp_version,
        }).encode()

    def laps(self) -> list[Lap]:
        """One lap per episode that ended. The first step is logged one step after the lap
        starts, so a lap's time is its steps' span plus one step."""
        laps = []
        for number, (_, episode) in enumerate(sorted(self.episodes.items()), start=1):
            if episode.end is None or episode.steps < 2:
                continue
            tstamp, progress, status = episode.end
            step = (episode.last - episode.first) / (episode.steps - 1)
            laps.append(Lap(
                trial=number,
                time_ms=min(limits.MAX_LAP_MS, max(0, round((tstamp - episode.first + step) * 1000))),
                completion_pct=min(100.0, max(0.0, progress)),
                status=_STATUSES.get(status, status.replace("_", " ").capitalize())[:32],
                off_track=episode.spells.get("off_track", 0),
                crashes=episode.spells.get("crashed", 0),
                reversed=episode.spells.get("reversed", 0),
                immobilized=episode.spells.get("immobilized", 0),
            ))
        return laps


def read_log(path: Path, name: str) -> JobLog:
    """Scan a log file line by line (at most MAX_LOG_FILE_BYTES of it) for what its job printed."""
    digest = hashlib.sha256()
    log = JobLog(name=name, sha256="", size=0)
    block: list[str] | None = None
    for raw in _lines(path, name):
        digest.update(raw)
        log.size += len(raw)
        line = _PREFIX.sub("", raw.decode("utf-8", "replace").rstrip("\r\n"))
        if block is not None:
            block.append(line)
            if line.strip() == "}" or len(block) > 200:
                log.hyperparameters = _json_object("\n".join(block))
                block = None
        elif line.startswith(_TRACE):
            _add_step(log, line[len(_TRACE):])
        elif line.startswith("{'") and "'WORLD_NAME'" in line and log.params is None:
            values = _literal(line)
            if isinstance(values, dict):
                log.params = params_from_values(values, name)
        elif line.startswith(_ACTION_SPACE) and log.action_space is None:
            log.action_space = _literal(line[len(_ACTION_SPACE):])
        elif (found := _SENSORS.search(line)) and log.sensors is None:
            sensors = _literal(found[1])
            log.sensors = [str(s) for s in sensors] if isinstance(sensors, list) else None
            log.network, log.simapp_version, log.algorithm, log.action_space_type = found.groups()[1:]
        elif line.strip() == _HYPERPARAMETERS and log.hyperparameters is None:
            block = []
    log.sha256 = digest.hexdigest()
    return log


def _lines(path: Path, name: str) -> Any:
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as error:
        raise AssemblyError(name, "", f"cannot be read: {error.strerror or error}") from None
    with os.fdopen(descriptor, "rb") as handle:
        if not stat.S_ISREG(os.fstat(handle.fileno()).st_mode):
            raise AssemblyError(name, "", "is not a regular file")
        left = limits.MAX_LOG_FILE_BYTES
        while left > 0:
            try:
                line = handle.readline(min(left, limits.MAX_LOG_LINE_BYTES))
            except OSError as error:
                raise AssemblyError(name, "", f"cannot be read: {error.strerror or error}") from None
            if not line:
                return
            left -= len(line)
            yield line


def _literal(text: str) -> Any:
    """A Python literal as the simulation printed it (a dict or a list), or None."""
    text = text.strip()
    if len(text) > limits.MAX_LOG_LINE_BYTES:
        return None
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError, MemoryError, RecursionError, TypeError):
        return None


def _json_object(text: str) -> dict[str, Any] | None:
    try:
        value = json.loads(text)
    except (ValueError, RecursionError):
        return None
    return value if isinstance(value, dict) else None


def _add_step(log: JobLog, text: str) -> None:
    columns = text.split(",")
    if len(columns) <= _STATUS:
        return
    try:
        number, tstamp, progress = int(columns[_EPISODE]), float(columns[_TSTAMP]), float(columns[_PROGRESS])
    except ValueError:
        return
    if not (0 <= number <= 100_000 and 0 <= tstamp <= 1e10 and 0 <= progress <= 1000):
        return  # also refuses NaN
    status, done = columns[_STATUS].strip()[:32], columns[_DONE].strip() == "True"
    episode = log.episodes.get(number)
    if episode is None:
        if len(log.episodes) >= limits.MAX_LAPS_PER_RUN:
            return
        log.episodes[number] = _Episode(first=tstamp, last=tstamp, status=status,
                                        spells={status: 1}, end=(tstamp, progress, status) if done else None)
        return
    episode.add(tstamp, progress, status, done)
