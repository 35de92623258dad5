"""The simulation (RoboMaker / simapp) and training (SageMaker) logs of a run: what the job
printed about itself.

Console, DeepRacer on AWS and DeepRacer-for-Cloud jobs all run the same simulation application,
which prints the job's parameters as a Python dict, ``Action space from file: [...]``, a
``Sensor list [...], network ..., training_algorithm ..., action_space_type ...`` line, the
hyperparameters as a JSON block after ``Using the following hyper-parameters``, and one
``SIM_TRACE_LOG:`` line per step. DeepRacer on AWS prefixes each line with the names of the
processes it went through (``[download_params_and_roslaunch_agent.py-1] ``).

The hyperparameters block is the job's own: a training job prints the model's, but an evaluation
job prints the evaluation worker's defaults (PPO: discount 0.999, mean squared error, 10 epochs,
e-greedy 0.05; SAC the same and alpha 0.2), whatever the model was trained with. ``job`` tells
which kind of job wrote the log.

Two formats are recognised but not read: logs of 2019, whose parameters the job printed only
ROS-style (`` * /WORLD_NAME: reInvent2019_track``, long values cut short) and whose trace lines
have no episode status, and CloudWatch's CSV export of a log (``@timestamp,@message`` rows).
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
from typing import Any, Literal

from . import limits
from .errors import AssemblyError
from .params import RunParams, params_from_values
from .record import Lap

Job = Literal["evaluation", "training"]

_PREFIX = re.compile(r"^(?:\[[\w.:-]+\] )+")
_SENSORS = re.compile(r"Sensor list (\[[^\]]*\]), network (\S+), simapp_version (\S+), "
                      r"training_algorithm (\S+), action_space_type (\w+)")
_ROS_PARAM = re.compile(r"^ \* /(?P<key>[A-Z][A-Z0-9_]*): (?P<value>.*)$")
_METADATA_KEY = re.compile(r"Successfully downloaded model metadata\s+from s3 key (?P<key>\S+)")
_CSV_EXPORT = re.compile(r'^\ufeff?"?@?timestamp"?,"?@?(message|logStream|ingestionTime)', re.IGNORECASE)
_ACTION_SPACE = ("Action space from file: ", "Loaded action space from file: ")
_HYPERPARAMETERS = "Using the following hyper-parameters"
_TRACE = "SIM_TRACE_LOG:"
_JOB_MARKERS: tuple[tuple[str, Job], ...] = (
    ("markov.evaluation_worker", "evaluation"), ("run_evaluation_rl_agent", "evaluation"),
    ("evaluation_worker.py", "evaluation"), ("markov.rollout_worker", "training"),
    ("run_rollout_rl_agent", "training"), ("markov.training_worker", "training"),
    ("Training> Name=", "training"),
)
# SIM_TRACE_LOG columns: episode, step, x, y, heading, steering, speed, action, reward, done,
# all_wheels_on_track, progress, closest_waypoint, track_len, tstamp, episode_status, ...
_EPISODE, _DONE, _PROGRESS, _TSTAMP, _STATUS = 0, 9, 11, 14, 15
_STATUSES = {"lap_complete": "Lap complete", "off_track": "Off track", "crashed": "Crashed",
             "reversed": "Reversed", "immobilized": "Immobilized", "time_up": "Time up"}
#: The episode statuses that reset the car (or end the lap): each spell of one counts once.
_RESETS = ("off_track", "crashed", "immobilized", "reversed")


@dataclass
class _Episode:
    """One episode's steps, summed up as they are read (a long log has millions of steps)."""

    first: float
    last: float
    progress: float
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
        self.last, self.progress, self.steps = tstamp, progress, self.steps + 1
        if done:
            self.end = (tstamp, progress, status)

    def ended(self, followed: bool) -> tuple[float, float, str] | None:
        """How the lap ended: its last step, or, in a continuous evaluation (where the next lap
        is the next episode and no step says done), the step that reached 100 %."""
        if self.end is None and followed and self.progress >= 100:
            return self.last, self.progress, "in_progress"
        return self.end


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
    #: The job's kind, from its parameters or the worker it ran (None: the log does not say).
    marked_job: Job | None = None
    #: The S3 key of the model_metadata.json the job loaded.
    metadata_key: str | None = None
    #: Parameters printed ROS-style (`` * /KEY: value``), which every console log of 2019 on has.
    ros_params: dict[str, str] = field(default_factory=dict)
    #: Trace lines of the 2019 format (no episode status), which are not read.
    old_trace_lines: int = 0
    csv_export: bool = False

    @property
    def job(self) -> Job | None:
        if self.params is not None:
            return self.params.kind
        ros_job = self.ros_params.get("JOB_TYPE", "").upper()
        if ros_job in ("EVALUATION", "SUBMISSION", "RACING"):
            return "evaluation"
        if ros_job == "TRAINING":
            return "training"
        return self.marked_job

    @property
    def is_evaluation(self) -> bool:
        return self.job == "evaluation"

    @property
    def unread_format(self) -> str | None:
        """What makes the log one drboard does not read, or None."""
        if self.csv_export:
            return "a CloudWatch CSV export"
        if self.params is None and (self.ros_params or self.old_trace_lines) and not self.laps():
            return "a log of the 2019 format (parameters printed ROS-style, trace lines without status)"
        return None

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
        starts, so a lap's time is its steps' span plus one step; the pauses of penalties are
        logged steps, so they are in it, as in the metrics file's time."""
        return [_lap(number, episode, end) for number, (episode, end)
                in enumerate(self._ended(), start=1)]

    def lap_starts_ms(self) -> list[float]:
        """When each lap's first step was logged, in the simulation's milliseconds."""
        return [episode.first * 1000 for episode, _ in self._ended()]

    def _ended(self) -> list[tuple[_Episode, tuple[float, float, str]]]:
        ordered = [episode for _, episode in sorted(self.episodes.items())]
        ended = []
        for index, episode in enumerate(ordered):
            end = episode.ended(followed=index + 1 < len(ordered))
            if end is not None and episode.steps >= 2:
                ended.append((episode, end))
        return ended


def _lap(number: int, episode: _Episode, end: tuple[float, float, str]) -> Lap:
    tstamp, progress, status = end
    step = (episode.last - episode.first) / (episode.steps - 1)
    return Lap(
        trial=number,
        time_ms=min(limits.MAX_LAP_MS, max(0, round((tstamp - episode.first + step) * 1000))),
        completion_pct=min(100.0, max(0.0, progress)),
        status=_STATUSES.get(status, status.replace("_", " ").capitalize())[:32],
        off_track=episode.spells.get("off_track", 0),
        crashes=episode.spells.get("crashed", 0),
        # as the metrics file counts them: every off-track, crash, immobilisation and reversal,
        # the one that ended the lap included
        resets=sum(episode.spells.get(cause, 0) for cause in _RESETS),
        reversed=episode.spells.get("reversed", 0),
        immobilized=episode.spells.get("immobilized", 0),
    )


def read_log(path: Path, name: str) -> JobLog:
    """Scan a log file line by line (at most MAX_LOG_FILE_BYTES of it) for what its job printed."""
    digest = hashlib.sha256()
    log = JobLog(name=name, sha256="", size=0)
    reader = _LineReader(log)
    for raw in _lines(path, name):
        digest.update(raw)
        if log.size == 0 and _CSV_EXPORT.match(raw.decode("utf-8", "replace")):
            log.csv_export = True
        log.size += len(raw)
        reader.feed(_PREFIX.sub("", raw.decode("utf-8", "replace").rstrip("\r\n")))
    log.sha256 = digest.hexdigest()
    return log


class _LineReader:
    """Reads one line at a time into the log: its parts are printed once, its trace throughout."""

    def __init__(self, log: JobLog) -> None:
        self.log = log
        self.block: list[str] | None = None

    def feed(self, line: str) -> None:
        if self.block is not None:
            self._hyperparameter_line(line)
        elif line.startswith(_TRACE):
            _add_step(self.log, line[len(_TRACE):])
        else:
            any(read(line) for read in (self._params, self._action_space, self._hyperparameters,
                                        self._sensors, self._ros_param, self._metadata_key, self._job))

    def _hyperparameter_line(self, line: str) -> None:
        assert self.block is not None
        self.block.append(line)
        if line.strip() == "}" or len(self.block) > 200:
            self.log.hyperparameters = _json_object("\n".join(self.block))
            self.block = None

    # Each reader below takes a line it recognises (and returns True), once its part is read.

    def _params(self, line: str) -> bool:
        if not (line.startswith("{'") and "'WORLD_NAME'" in line and self.log.params is None):
            return False
        values = _literal(line)
        if isinstance(values, dict):
            self.log.params = params_from_values(values, self.log.name)
        return True

    def _action_space(self, line: str) -> bool:
        if not (line.startswith(_ACTION_SPACE) and self.log.action_space is None):
            return False
        self.log.action_space = _literal(line.split(": ", 1)[1])
        return True

    def _hyperparameters(self, line: str) -> bool:
        if line.strip() != _HYPERPARAMETERS or self.log.hyperparameters is not None:
            return False
        self.block = []
        return True

    def _sensors(self, line: str) -> bool:
        found = _SENSORS.search(line) if self.log.sensors is None else None
        if found is None:
            return False
        sensors = _literal(found[1])
        self.log.sensors = [str(s) for s in sensors] if isinstance(sensors, list) else None
        self.log.network, self.log.simapp_version, self.log.algorithm, self.log.action_space_type = \
            found.groups()[1:]
        return True

    def _ros_param(self, line: str) -> bool:
        ros = _ROS_PARAM.match(line) if len(self.log.ros_params) < 200 else None
        if ros is None:
            return False
        self.log.ros_params.setdefault(ros["key"], ros["value"].strip()[: limits.MAX_TEXT_CHARS])
        return True

    def _metadata_key(self, line: str) -> bool:
        key = _METADATA_KEY.search(line) if self.log.metadata_key is None else None
        if key is None:
            return False
        self.log.metadata_key = key["key"][: limits.MAX_TEXT_CHARS]
        return True

    def _job(self, line: str) -> bool:
        if self.log.marked_job is None:
            self.log.marked_job = next((job for marker, job in _JOB_MARKERS if marker in line), None)
        return self.log.marked_job is not None


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
        log.old_trace_lines += len(columns) == _STATUS
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
        log.episodes[number] = _Episode(first=tstamp, last=tstamp, progress=progress, status=status,
                                        spells={status: 1}, end=(tstamp, progress, status) if done else None)
        return
    episode.add(tstamp, progress, status, done)
