"""Pushing a run, with the trust rules that go with it: who may push as whom (aliases), copied
runs, and the board's window and submission limits."""

from __future__ import annotations

import hashlib
import json
import math
from datetime import datetime, timedelta

from drboard_assembler.limits import MAX_RECORD_BYTES
from drboard_assembler.record import Alias, EvaluationRun, Record
from pydantic import TypeAdapter, ValidationError

from .. import display, ranking
from ..errors import (
    AliasTaken,
    Banned,
    CopiedRun,
    DomainError,
    InvalidQuery,
    NotAuthorized,
    NotSignedIn,
    SubmissionLimitReached,
    SubmissionTooLarge,
    TooSoon,
)
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import AliasClaim, Board, Entry, RacerTally, Submission, SubmissionLimits
from ..models.notices import EntryChange
from ..models.views import Me, PushReceipt
from ..stores.base import AliasConflict, FingerprintTaken, LimitReached, RecordArchive
from ..views import design_of, entry_view, history_item
from .boards import BoardKeeper, check_open, racer_key

_ALIAS: TypeAdapter[str] = TypeAdapter(Alias)


class Pushing:
    def __init__(self, keeper: BoardKeeper, archive: RecordArchive | None) -> None:
        self.keeper = keeper
        self.store = keeper.store
        self.archive = archive

    def push(self, record: Record, board_id: str | None = None,
             caller: Caller | None = LOCAL_ORGANISER) -> PushReceipt:
        """Store a run on its board. A run already on the board is a duplicate: it changes
        nothing and is answered whatever the board's window and limits (it never counts).
        ``caller`` is who pushes: a racer may push only as the alias their sign-in holds (their
        first push claims it); organisers push as anyone; None (unsigned) is refused."""
        check_record_size(record)
        now = self.keeper.clock()
        self._check_pusher(caller, record.racer, now)
        board = self.keeper.for_record(record, board_id, now).board
        key = racer_key(record.racer)
        if key in board.banned:
            raise Banned(f"{record.racer!r} is banned from {board.board_id!r} by its organisers")
        stored = self.store.get_submission(board.board_id, key, record.submission_id)
        if stored is not None:
            return self._duplicate_receipt(stored, record.racer)
        check_open(board, now)
        submission, entry = scored_write(record, board, now)
        limits = SubmissionLimits(now=now, cooldown_s=board.cooldown_s,
                                  max_submissions=board.max_submissions)
        audit = self.keeper.event(board.board_id, "push", caller, now, racer=record.racer,
                                  submission_id=record.submission_id, detail=record.model_name)
        keep_in_archive(self.archive, board.board_id, record)
        before = self.store.get_entry(board.board_id, key) if self.keeper.listener else None
        try:
            outcome = self.store.record_submission(submission, record, entry, limits,
                                                   fingerprints=evaluation_fingerprints(record),
                                                   audit=audit)
        except LimitReached as refused:
            raise _limit_error(board, record.racer, refused.tally, now) from None
        except FingerprintTaken as copy:
            raise CopiedRun(f"this run's evaluation is already on {board.board_id!r} under "
                            f"another racer ({copy.racer_key}): a copied run is refused") from None
        if outcome.duplicate:  # pushed twice at once: the other push stored it first
            stored = self.store.get_submission(board.board_id, key, record.submission_id)
            return self._duplicate_receipt(stored or submission, record.racer)
        if outcome.improved and self.keeper.listener is not None:
            self.keeper.listener(EntryChange(board_id=board.board_id, before=before,
                                             after=outcome.entry, at=now))
        return self._receipt(submission, outcome.entry, outcome.duplicate, outcome.improved)

    def _duplicate_receipt(self, stored: Submission, racer: str) -> PushReceipt:
        best = self.store.get_entry(stored.board_id, stored.racer_key)
        if best is None:
            raise NotAuthorized(f"{racer!r} was taken off {stored.board_id!r} by its organisers; "
                                "this run stays off it")
        return self._receipt(stored, best, duplicate=True, improved=False)

    def _receipt(self, submission: Submission, best: Entry, duplicate: bool,
                 improved: bool) -> PushReceipt:
        rank = self.store.count_better(best.board_id, best.score_key) + 1
        stored, top = self.store.front_page(best.board_id, 1)
        return PushReceipt(
            status="duplicate" if duplicate else "created",
            board_id=best.board_id,
            submission_id=submission.submission_id,
            improved=improved,
            rank=rank,
            participants=stored.participants if stored else 1,
            entry=entry_view(best, rank, top[0] if top else None),
            submission=history_item(submission, best),
        )

    # ---- who is pushing -------------------------------------------------------------------

    def _check_pusher(self, caller: Caller | None, racer: str, now: datetime) -> None:
        if caller is None:
            raise NotSignedIn("sign in to push: `drboard login` for a deployed board, "
                              "`drboard join CODE` for a `drboard serve` board")
        if caller.organiser:
            return
        claim = self.store.alias_of(caller.principal) or self._claim(caller, racer, now)
        if claim.racer_key != racer_key(racer):
            raise AliasTaken(f"you push as {claim.alias!r}: this run is {racer!r}'s "
                             "(give `--racer` your own alias)")

    def _claim(self, caller: Caller, alias: str, now: datetime) -> AliasClaim:
        claim = AliasClaim(racer_key=racer_key(alias), alias=alias, principal=caller.principal,
                           claimed_at=now)
        try:
            return self.store.claim_alias(claim)
        except AliasConflict as conflict:
            if conflict.holder.principal == caller.principal:
                raise AliasTaken(f"you push as {conflict.holder.alias!r}, not {alias!r}: "
                                 "an alias is claimed once") from None
            raise AliasTaken(f"the alias {alias!r} belongs to another racer") from None

    def me(self, caller: Caller | None = LOCAL_ORGANISER) -> Me:
        if caller is None:
            raise NotSignedIn("not signed in: `drboard login` or `drboard join CODE`")
        claim = self.store.alias_of(caller.principal)
        return Me(principal=caller.principal, name=caller.name, organiser=caller.organiser,
                  alias=claim.alias if claim else None)

    def claim_alias(self, alias: str, caller: Caller | None = LOCAL_ORGANISER) -> Me:
        """Claim the alias the caller will push as (once: an alias is not renamed)."""
        if caller is None:
            raise NotSignedIn("sign in to claim an alias: `drboard login` or `drboard join CODE`")
        try:
            alias = _ALIAS.validate_python(alias)
        except ValidationError as error:
            message = error.errors()[0]["msg"].removeprefix("Value error, ")
            raise InvalidQuery(message, detail=[{"loc": "alias", "msg": message,
                                                 "type": "value_error"}]) from None
        self._claim(caller, alias, self.keeper.clock())
        return self.me(caller)


def keep_in_archive(archive: RecordArchive | None, board_id: str, record: Record) -> None:
    """Keep the record in the archive before the push commits: a failed archive write
    stores nothing (a store error, 503). Its key is the record's content hash, so a push
    refused or retried afterwards leaves at most an object no row refers to."""
    if archive is not None:
        archive.put(board_id, record)


def evaluation_fingerprints(record: Record) -> list[str]:
    """The sha256 of each evaluation's laps that completed a lap (what a copied run keeps,
    whatever it renames): the board refuses one already there under another racer."""
    return sorted({_fingerprint(run) for run in record.evaluations if run.laps_completed})


def _fingerprint(run: EvaluationRun) -> str:
    laps = [lap.model_dump(mode="json") for lap in run.laps]
    return hashlib.sha256(json.dumps(laps, sort_keys=True).encode()).hexdigest()


def check_record_size(record: Record) -> None:
    """Every board, embedded or in the cloud, holds a record to the same bound in bytes (its
    JSON, as the assembler measures it); the record's model bounds the rest (string lengths,
    laps, runs, curve points)."""
    size = len(record.model_dump_json().encode("utf-8"))
    if size > MAX_RECORD_BYTES:
        raise SubmissionTooLarge(f"the record is {size} bytes, over the {MAX_RECORD_BYTES} "
                                 "bytes a record may have")


def scored_write(record: Record, board: Board, at: datetime) -> tuple[Submission, Entry]:
    """The submission and the candidate entry a record makes on a board, as of ``at``: what a
    push (or an import) hands the store."""
    score = ranking.score_record(record, board.rules)
    key = racer_key(record.racer)
    score_key = ranking.score_key(score)
    submission = Submission(
        board_id=board.board_id, racer=record.racer, racer_key=key,
        submission_id=record.submission_id, model_name=record.model_name,
        submitted_at=at, score=score, score_key=score_key,
    )
    entry = Entry(
        board_id=board.board_id, racer=record.racer, racer_key=key,
        model_name=record.model_name, submission_id=record.submission_id,
        achieved_at=at, score=score, design=design_of(record), score_key=score_key,
        rank_key=ranking.rank_key(score_key, at, key),
    )
    return submission, entry


def _limit_error(board: Board, racer: str, tally: RacerTally, now: datetime) -> DomainError:
    cap = board.max_submissions
    if cap is not None and tally.submissions >= cap:
        return SubmissionLimitReached(
            f"{racer} has made all {cap} submissions {board.board_id!r} allows")
    last = tally.last_submitted_at or now
    ready = last + timedelta(seconds=board.cooldown_s)
    wait = max(1, math.ceil((ready - now).total_seconds()))
    return TooSoon(f"{board.board_id!r} takes one submission every "
                   f"{display.duration(board.cooldown_s)} per racer: {racer} may submit again at "
                   f"{display.when(ready)} (in {display.duration(wait)})", wait)
