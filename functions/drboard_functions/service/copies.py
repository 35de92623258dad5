"""Copied runs: what identifies a run whatever a copier edits, who pushed it first, and runs whose
laps are a few milliseconds from another racer's.

- A run's **fingerprint** is what scores: each lap's time and completion, in order. Renumbering
  the trials, changing a status's case or shifting or dropping the timestamps leaves it as it
  is. A run of fewer than ``MIN_LAPS`` laps says too little to tell a copy from two racers who
  happened to drive the same time, so its fingerprint stays its laps' whole content (an exact
  copy is still caught; a retouched one is not).
- The **first author** of a run is the racer whose submission of it came first, on any board of
  the deployment: they hold it everywhere. Another racer's push of the same run is refused
  (``CopiedRun``); the author's own push is taken wherever a copy got first (the copy is flagged
  ``copied-run`` for the organiser). Where drboard stores the run anyway — an organiser's push
  or import of it — both runs are flagged ``copied-run`` and the organiser decides.
- A **near-copy** is a run with at least ``MIN_LAPS`` complete laps whose complete laps, sorted,
  are each within ``NEAR_MS`` of another racer's run on the same track and direction (a lap a
  millisecond slower, an incomplete lap added, the laps reordered): it is stored and flagged
  ``near-copy`` for the organiser.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field

from drboard_assembler.record import EvaluationRun, Record

from .. import display
from ..errors import CopiedRun
from ..models.domain import RunAuthor, RunPrint
from ..stores.base import BoardStore, RunSeen

#: Runs of at least this many laps are fingerprinted by their times and compared for near-copies.
MIN_LAPS = 3
#: How far apart two laps may be and still be the same lap of a near-copy.
NEAR_MS = 5

COPIED = "copied-run"
NEAR_COPY = "near-copy"
#: An alias that could pass for another racer's on the board (an organiser's push or import).
LOOKALIKE = "lookalike"


def run_fingerprint(run: EvaluationRun) -> str:
    if len(run.laps) >= MIN_LAPS:
        laps = [[lap.time_ms, round(lap.completion_pct * 100)] for lap in run.laps]
        return hashlib.sha256(("laps/1 " + json.dumps(laps)).encode()).hexdigest()
    content = [lap.model_dump(mode="json") for lap in run.laps]
    return hashlib.sha256(json.dumps(content, sort_keys=True).encode()).hexdigest()


def evaluation_fingerprints(record: Record) -> list[str]:
    """The fingerprints of the record's evaluations that completed a lap: the board refuses
    one already there under another racer."""
    return sorted({run_fingerprint(run) for run in record.evaluations if run.laps_completed})


def lane(record: Record) -> str:
    """Where lap times compare: the track, its direction and the race type."""
    return f"{record.track}|{'cw' if record.direction == 'cw' else ''}|{record.race_type.value}"


def run_prints(record: Record) -> list[RunPrint]:
    prints: dict[str, RunPrint] = {}
    for run in record.evaluations:
        if not run.laps_completed:
            continue
        complete = sorted(run.completed_times)
        fingerprint = run_fingerprint(run)
        prints[fingerprint] = RunPrint(fingerprint=fingerprint, lane=lane(record),
                                       laps_ms=complete if len(complete) >= MIN_LAPS else None)
    return list(prints.values())


def same_laps(one: list[int], other: list[int]) -> bool:
    return len(one) == len(other) and all(
        abs(a - b) <= NEAR_MS for a, b in zip(sorted(one), sorted(other), strict=True))


@dataclass
class Verdict:
    """What the runs of a submission are, against every other racer's."""

    flags: list[str] = field(default_factory=list)
    #: Fingerprints this racer first authored and another racer holds on the board.
    take_over: list[str] = field(default_factory=list)
    #: Other racers' runs to flag for the organiser, (author, flag), and why.
    others: list[tuple[RunAuthor, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def flag(self, flag: str, note: str) -> None:
        if flag not in self.flags:
            self.flags.append(flag)
        self.notes.append(note)


def judge(store: BoardStore, board_id: str, racer_key: str, prints: list[RunPrint],
          seen: list[RunSeen], *, refuse: bool) -> Verdict:
    """Who holds each run of a submission, from who else drove each (``seen``, read with the
    push's first reads). With ``refuse`` (a racer's push), a run another racer pushed first is
    refused (CopiedRun); otherwise (an organiser's hand) it is stored and both runs flagged."""
    verdict = Verdict()
    for run, (authors, near_runs) in zip(prints, seen, strict=True):
        others = [author for author in authors if author.racer_key != racer_key]
        if others:
            mine = next((a for a in authors if a.racer_key == racer_key), None)
            first = others[0]
            if mine is None or mine.first_at >= first.first_at:
                if refuse:
                    raise CopiedRun(
                        f"this run's laps are already on {first.board_id!r} under another racer "
                        f"({first.racer_key!r}, since {display.when(first.first_at)}): a copied "
                        "run is refused (if the run is yours, ask the board's organiser)")
                verdict.flag(COPIED, f"the same laps as {first.racer_key!r}'s on {first.board_id!r}")
                verdict.others += [(author, COPIED) for author in others]
            else:
                holder = store.fingerprint_holder(board_id, run.fingerprint)
                if holder is not None and holder != racer_key:
                    verdict.take_over.append(run.fingerprint)
                verdict.others += [(author, COPIED) for author in others]
        if run.laps_ms:
            for near in near_runs:
                if (near.racer_key != racer_key and near.fingerprint != run.fingerprint
                        and same_laps(run.laps_ms, near.laps_ms)):
                    verdict.flag(NEAR_COPY, f"laps within {NEAR_MS} ms of {near.racer_key!r}'s "
                                            f"on {near.board_id!r}")
    return verdict
