"""`drboard push --watch`: push each new evaluation of a training folder while it trains.

Every evaluation metrics file is pushed as a record of its own. DeepRacer rewrites an
evaluation's metrics file after every lap, so a file is pushed once it is complete: it holds as
many laps as the evaluation's parameters ask for (``NUMBER_OF_TRIALS``), or, when no parameters
say, nothing has written to it for ``settle_s`` seconds. A file that cannot be read is tried
again on the next polls (it may be half-written), then reported once and skipped until it
changes.

What was pushed is remembered across restarts by the content of each evaluation metrics file
(``PushedEvaluations``): while training goes on, the record around an old evaluation changes (its
training summary and parameters grow), so the board alone would take it for a new run.

The board's cooldown (``TooSoon``) is waited out and a board that cannot be reached is retried
with backoff, forever; a board that will take nothing more (closed, limit reached, not found, not
authorised) stops the watch with its error. Ctrl-C stops it at any point.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path

from drboard_assembler import AssemblyError, Overrides, Record, assemble, evaluation_files, planned_trials
from drboard_functions import errors as domain
from drboard_functions.display import plural
from drboard_functions.models.views import PushAccepted, PushReceipt
from rich.console import Console
from rich.status import Status
from rich.text import Text

from . import render, terminal
from .target import BoardClient

DEFAULT_INTERVAL_S = 10.0
DEFAULT_SETTLE_S = 60.0
FIRST_RETRY_S = 1.0
MAX_RETRY_S = 60.0
ATTEMPTS_BEFORE_SKIPPING = 3

# The board refuses this one evaluation; the next may be fine.
_REFUSED_EVALUATION = (domain.InvalidSubmission, domain.SubmissionTooLarge, domain.BoardMismatch)

Signature = tuple[int, int]  # size, mtime in ns: a change means the file was written


MAX_REMEMBERED = 10_000  # evaluations per board and target


class PushedEvaluations:
    """The evaluation metrics files (by sha256) pushed to one board of one target, kept in a
    small JSON file in the user's data folder so a restarted watch pushes none of them again."""

    def __init__(self, path: Path, scope: str) -> None:
        self.path = path
        self.scope = scope
        self._digests = set(self._load().get(scope, []))

    def __contains__(self, digest: str) -> bool:
        return digest in self._digests

    def add(self, digest: str) -> None:
        if digest in self._digests:
            return
        self._digests.add(digest)
        everything = self._load()
        kept = [d for d in everything.get(self.scope, []) if d != digest][-(MAX_REMEMBERED - 1):]
        everything[self.scope] = [*kept, digest]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        temporary = self.path.with_suffix(".tmp")
        temporary.write_text(json.dumps(everything, indent=1) + "\n", "utf-8")
        temporary.replace(self.path)

    def _load(self) -> dict[str, list[str]]:
        try:
            value = json.loads(self.path.read_text("utf-8"))
        except (OSError, ValueError):
            return {}
        if not isinstance(value, dict):
            return {}
        return {k: [d for d in v if isinstance(d, str)] for k, v in value.items() if isinstance(v, list)}


def evaluation_digest(record: Record) -> str | None:
    """The sha256 of the one evaluation metrics file a watched record was assembled from."""
    sources = {run.source for run in record.evaluations}
    return next((f.sha256 for f in record.provenance if f.path in sources), None)


@dataclass
class WatchSummary:
    pushed: int = 0
    already_on_board: int = 0
    skipped: list[str] = field(default_factory=list)
    not_complete: int = 0
    last_racer: str | None = None


@dataclass
class _Pending:
    """An evaluation file seen but not pushed yet."""

    signature: Signature
    changed_at: float  # when the file was last written, as far as the watcher knows
    record: Record | None = None  # assembled from this content, waiting to be complete
    trials: int | None = None
    failures: int = 0


class Watcher:
    def __init__(self, folder: Path, board: BoardClient, overrides: Overrides,
                 board_id: str | None, *, console: Console | None = None, only_new: bool = False,
                 interval_s: float = DEFAULT_INTERVAL_S, settle_s: float = DEFAULT_SETTLE_S,
                 sleep: Callable[[float], None] | None = None,
                 clock: Callable[[], float] | None = None,
                 memory: PushedEvaluations | None = None) -> None:
        self.folder = folder
        self.memory = memory
        self.board = board
        self.overrides = overrides
        self.board_id = board_id
        self.console = console or terminal.console()
        self.interval_s = interval_s
        self.settle_s = settle_s
        self.sleep = sleep or time.sleep
        self.clock = clock or time.time
        self.summary = WatchSummary()
        self._ignore_existing = only_new
        self._looked_once = False
        self._done: set[str] = set()
        self._pushed_ids: set[str] = set()
        self._pending: dict[str, _Pending] = {}
        self._ignored: dict[str, Signature] = {}  # skipped, or there before --only-new: until changed
        self._status: Status | None = None

    # ---- the loop ----------------------------------------------------------------------------

    def run(self) -> WatchSummary:
        """Poll until Ctrl-C (KeyboardInterrupt), then print a summary. A board that will take
        nothing more raises its error after the summary."""
        try:
            self._say(f"Watching {self.folder} for new evaluations every {self.interval_s:g} s "
                      "(Ctrl-C to stop).")
            with self.console.status(Text(self._idle_text())) as status:
                self._status = status
                while True:
                    self.poll()
                    self._show(self._idle_text())
                    self.sleep(self.interval_s)
        except KeyboardInterrupt:
            pass
        finally:
            self._status = None
            self.summary.not_complete = len(self._pending)
            self.console.print(Text(self._summary_text()), soft_wrap=True)
        return self.summary

    def poll(self) -> None:
        """Look at the folder once and push every evaluation that is complete, in name order."""
        names = [n for n in evaluation_files(self.folder) if n not in self._done]
        if self._ignore_existing:
            self._ignore_existing = False
            self._ignored |= {n: s for n in names if (s := self._signature(n)) is not None}
        for name in names:
            record = self._complete_record(name)
            if record is not None:
                self._push(name, record)
        self._looked_once = True

    # ---- is an evaluation complete? -------------------------------------------------------------

    def _complete_record(self, name: str) -> Record | None:
        signature = self._signature(name)
        if signature is None:
            self._pending.pop(name, None)
            return None
        if self._ignored.get(name) == signature:
            return None
        self._ignored.pop(name, None)
        pending = self._track(name, signature)
        if pending.record is None:
            self._assemble(name, pending)
        record = pending.record
        if record is None:
            return None
        all_laps_in = pending.trials is not None and len(record.evaluations[0].laps) >= pending.trials
        quiet = self.clock() - pending.changed_at >= self.settle_s
        return record if all_laps_in or quiet else None

    def _track(self, name: str, signature: Signature) -> _Pending:
        """A file there when the watch starts was last written at its modification time; one
        that appears or changes later, when the watcher sees it (a copy or a sync may give it an
        older modification time than the moment it was written)."""
        pending = self._pending.get(name)
        if pending is None or pending.signature != signature:
            modified = signature[1] / 1e9
            changed_at = max(self.clock(), modified) if self._looked_once else modified
            pending = self._pending[name] = _Pending(signature, changed_at)
        return pending

    def _assemble(self, name: str, pending: _Pending) -> None:
        try:
            record = assemble(self.folder, self.overrides, evaluation=name)
            pending.trials = planned_trials(self.folder, name)
        except AssemblyError as error:
            pending.failures += 1
            if pending.failures >= ATTEMPTS_BEFORE_SKIPPING:
                self._skip(name, str(error))
            return
        pending.record = record

    def _signature(self, name: str) -> Signature | None:
        try:
            stat = (self.folder / name).stat()
        except FileNotFoundError:
            return None
        return stat.st_size, stat.st_mtime_ns

    # ---- pushing ---------------------------------------------------------------------------------

    def _push(self, name: str, record: Record) -> None:
        if record.submission_id in self._pushed_ids:
            self._finish(name)
            self._say(f"{name}: the same run as one pushed already; not pushed again.", style="dim")
            return
        digest = evaluation_digest(record)
        if self.memory is not None and digest is not None and digest in self.memory:
            self._finish(name)
            self.summary.already_on_board += 1
            self._say(f"{name}: pushed by an earlier watch; not pushed again.", style="dim")
            return
        try:
            receipt = self._push_until_answered(name, record)
        except _REFUSED_EVALUATION as error:
            self._skip(name, f"the board refused it: {error.message}")
            return
        self._pushed_ids.add(record.submission_id)
        if self.memory is not None and digest is not None:
            self.memory.add(digest)
        self._finish(name)
        if receipt.status == "duplicate":
            self.summary.already_on_board += 1
        else:
            self.summary.pushed += 1
        self.summary.last_racer = record.racer
        self.console.print(Text(f"{name}: ") + render.receipt_line(receipt), soft_wrap=True)

    def _push_until_answered(self, name: str, record: Record) -> PushReceipt | PushAccepted:
        """Push; wait out the board's cooldown and retry an unreachable board with backoff."""
        delay = FIRST_RETRY_S
        while True:
            try:
                return self.board.push(record, self.board_id)
            except domain.BoardUnreachable as error:
                if delay == FIRST_RETRY_S:
                    self._say(f"Cannot reach the board ({error.message}); retrying {name} with "
                              "backoff.", style="yellow")
                self._wait(delay, f"board unreachable · retrying {name}")
                delay = min(delay * 2, MAX_RETRY_S)
            except domain.TooSoon as error:
                wait_s = max(float(error.retry_after_s), 1.0)
                self._say(f"The board's cooldown is on: pushing {name} at {self._at(wait_s)}.",
                          style="yellow")
                self._wait(wait_s, f"waiting for the cooldown · pushing {name}")

    def _finish(self, name: str) -> None:
        self._done.add(name)
        self._pending.pop(name, None)

    def _skip(self, name: str, problem: str) -> None:
        pending = self._pending.pop(name, None)
        if pending is not None:
            self._ignored[name] = pending.signature
        if name not in self.summary.skipped:
            self.summary.skipped.append(name)
        problem = problem.removeprefix(f"{name}: ")
        self._say(f"Skipping {name}: {problem}", style="yellow")

    # ---- what the racer sees --------------------------------------------------------------------

    def _wait(self, seconds: float, doing: str) -> None:
        self._show(f"{doing} at {self._at(seconds)}")
        self.sleep(seconds)

    def _at(self, seconds: float) -> str:
        return datetime.fromtimestamp(self.clock() + seconds).strftime("%H:%M:%S")

    def _say(self, message: str, style: str = "") -> None:
        self.console.print(Text(message, style=style), soft_wrap=True)

    def _show(self, text: str) -> None:
        if self._status is not None:
            self._status.update(Text(text))

    def _idle_text(self) -> str:
        text = f"Watching {self.folder} · {self.summary.pushed} pushed"
        if self._pending:
            text += f" · {plural(len(self._pending), 'evaluation')} being written"
        return text + f" · next look at {self._at(self.interval_s)}"

    def _summary_text(self) -> str:
        summary = self.summary
        parts = [f"{plural(summary.pushed, 'evaluation')} pushed"]
        if summary.already_on_board:
            parts.append(f"{summary.already_on_board} already on the board")
        if summary.skipped:
            parts.append(f"{len(summary.skipped)} skipped")
        if summary.not_complete:
            parts.append(f"{summary.not_complete} not complete yet, not pushed")
        return f"Stopped watching {self.folder}: {', '.join(parts)}."
