"""Pushing a run, with the trust rules that go with it: who may push as whom (aliases and their
lookalikes), bans, copied runs, and the board's window and submission limits.

The order of a push: the cheap checks first (the board, bans, a duplicate, the window, the
racer's cooldown and maximum, a copied run), then the archive (a conditional put: a retry adds
no version), then one write that stores the submission and claims what the push claims — the
alias, its skeleton on the board, its runs' fingerprints — on condition that the board's
settings and the event's bans are still those the push was checked against; when they changed
meanwhile, the push is checked again. Once that write has committed, the answer is a success:
a receipt, or 202 with where to read it when the board cannot say the rank just then.
"""

from __future__ import annotations

import math
from datetime import datetime, timedelta
from urllib.parse import quote

from drboard_assembler.aliases import confusable_skeleton
from drboard_assembler.limits import MAX_RECORD_BYTES
from drboard_assembler.record import Alias, Record
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
    StoreBusy,
    StoreError,
    SubmissionLimitReached,
    SubmissionTooLarge,
    TooSoon,
)
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import (
    AliasClaim,
    Board,
    Entry,
    EventBans,
    RacerTally,
    Submission,
    SubmissionLimits,
    with_flag,
)
from ..models.views import Me, PushAccepted, PushReceipt
from ..stores.base import (
    AliasConflict,
    BoardChanged,
    FingerprintTaken,
    LimitReached,
    LookalikeTaken,
    RecordArchive,
    StoredBoard,
)
from ..views import design_of, entry_view, history_item
from .boards import BoardKeeper, check_open, default_board_id, racer_key
from .copies import NEAR_MS, Verdict, judge, run_prints

_ALIAS: TypeAdapter[str] = TypeAdapter(Alias)
#: How many times a push is checked again when the board's settings change under it.
SETTINGS_ATTEMPTS = 5
#: The principal of an alias an organiser keeps for a racer who has not signed in yet.
RESERVED = "reserved:"


class Pushing:
    def __init__(self, keeper: BoardKeeper, archive: RecordArchive | None) -> None:
        self.keeper = keeper
        self.store = keeper.store
        self.archive = archive

    def push(self, record: Record, board_id: str | None = None,
             caller: Caller | None = LOCAL_ORGANISER) -> PushReceipt | PushAccepted:
        """Store a run on its board. A run already on the board is a duplicate: it changes
        nothing and is answered whatever the board's window and limits (it never counts).
        ``caller`` is who pushes: a racer may push only as the alias their sign-in holds (their
        first stored push claims it); organisers push as anyone; None (unsigned) is refused."""
        record_json = check_record_size(record)
        if caller is None:
            raise NotSignedIn("sign in to push: `drboard login` for a deployed board, "
                              "`drboard join CODE` for a `drboard serve` board")
        now = self.keeper.clock()
        claim = self._new_claim(caller, record.racer, now)
        board_id = board_id or default_board_id(record.track, record.direction, record.race_type)
        key = racer_key(record.racer)
        prints = run_prints(record)
        skeleton = confusable_skeleton(record.racer)
        archived = False
        for _ in range(SETTINGS_ATTEMPTS):
            # The board, the event's bans, a duplicate, the racer's entry and who else drove
            # each run: read at once (again when the board's settings changed meanwhile).
            read = self.store.push_reads(board_id, key, record.submission_id, prints, NEAR_MS)
            stored_board = self.keeper.for_record(record, board_id, read.board, now)
            board = stored_board.board
            check_not_banned(board, read.bans, record.racer, caller)
            if read.submission is not None:
                return self._duplicate_receipt(read.submission, read.entry, record.racer)
            check_open(board, now)
            self._check_final(stored_board, record.racer)
            self._check_limits(board, key, record.racer, now)
            verdict = judge(self.store, board_id, key, prints, read.runs, refuse=not caller.organiser)
            submission, entry = scored_write(record, board, now, verdict.flags)
            if not archived:
                keep_in_archive(self.archive, board_id, record.submission_id, record_json)
                archived = True
            for fingerprint in verdict.take_over:
                self.store.hand_over_fingerprint(board_id, fingerprint, key)
            limits = SubmissionLimits(now=now, cooldown_s=board.cooldown_s,
                                      max_submissions=board.max_submissions,
                                      settings_version=stored_board.settings_version,
                                      bans_version=read.bans_version, entry_seen=read.entry)
            audit = self.keeper.event(board_id, "push", caller, now, racer=record.racer,
                                      submission_id=record.submission_id, detail=record.model_name)
            try:
                outcome = self.store.record_submission(
                    submission, record_json, entry, limits,
                    fingerprints=[p.fingerprint for p in prints],
                    audit=audit, runs=prints, claim=claim, skeleton=skeleton)
            except BoardChanged:
                continue  # a ban, a window or a limit changed meanwhile: check again
            except LimitReached as refused:
                raise _limit_error(board, record.racer, refused.tally, now) from None
            except FingerprintTaken as copy:
                raise CopiedRun(f"this run's evaluation is already on {board_id!r} under "
                                f"another racer ({copy.racer_key}): a copied run is refused") from None
            except LookalikeTaken as lookalike:
                raise AliasTaken(f"the alias {record.racer!r} could pass for "
                                 f"{lookalike.racer_key!r}, another racer on {board_id!r}: "
                                 "choose an alias that does not look like theirs") from None
            except AliasConflict as conflict:
                raise _alias_taken(conflict.holder, caller, record.racer) from None
            break
        else:
            raise StoreBusy(f"the settings of {board_id!r} kept changing while the push was "
                            "checked; nothing was stored, try again")
        if outcome.duplicate:  # pushed twice at once: the other push stored it first
            stored = self.store.get_submission(board_id, key, record.submission_id)
            return self._duplicate_receipt(stored or submission, self.store.get_entry(board_id, key),
                                           record.racer)
        if outcome.improved and self.keeper.listener is not None:
            from ..models.notices import EntryChange  # only `drboard serve` listens

            self.keeper.listener(EntryChange(board_id=board_id, before=read.entry,
                                             after=outcome.entry, at=now))
        self._tell_organiser(board_id, record, verdict, caller, now)
        try:
            return self._receipt(submission, outcome.entry, outcome.duplicate, outcome.improved)
        except StoreError:  # stored: only the rank could not be read back just now
            return PushAccepted(
                board_id=board_id, submission_id=record.submission_id, racer=record.racer,
                receipt=f"/boards/{quote(board_id, safe='')}/racers/{quote(record.racer, safe='')}",
                message="stored; the board could not read its rank back just now "
                        "(`drboard status` shows it, and pushing the run again answers it)")

    def _check_final(self, stored: StoredBoard, racer: str) -> None:
        """A season's final takes its qualifiers only (``NotQualified``). The seasons' rules are
        loaded for a board that is a final: a push to any other board does without them, and
        one to a board no season ever took in does not look for its seasons."""
        if not stored.maybe_in_a_season:
            return
        board_id = stored.board.board_id
        finals = [link for link in self.store.season_links(board_id) if link.final]
        if finals:
            from .seasons import check_entrant

            check_entrant(self.keeper, board_id, racer, finals)

    def _check_limits(self, board: Board, key: str, racer: str, now: datetime) -> None:
        """The racer's cooldown and maximum, before the archive is written (the write checks
        them again, atomically)."""
        if not board.cooldown_s and board.max_submissions is None:
            return
        tally = self.store.tally(board.board_id, key)
        cap = board.max_submissions
        last = tally.last_submitted_at
        if (cap is not None and tally.submissions >= cap) or (
                board.cooldown_s and last is not None
                and (now - last).total_seconds() < board.cooldown_s):
            raise _limit_error(board, racer, tally, now)

    def _tell_organiser(self, board_id: str, record: Record, verdict: Verdict,
                        caller: Caller, now: datetime) -> None:
        """Flag what the organiser should look at: this run, and the other racers' runs it
        copies or was copied from. The push has committed: a failure here is not the racer's
        (the next `drboard board recheck` flags the same)."""
        try:
            for note in verdict.notes:
                self.keeper.audit(board_id, "flag", caller, racer=record.racer,
                                  submission_id=record.submission_id, detail=note)
            for author, flag in verdict.others:
                if self.store.flag_submission(author.board_id, author.racer_key,
                                              author.submission_id, flag):
                    self.keeper.audit(author.board_id, "flag", caller, racer=author.racer_key,
                                      submission_id=author.submission_id,
                                      detail=f"{flag}: the same laps as {record.racer!r}'s on "
                                             f"{board_id!r}")
        except StoreError:
            pass

    def _duplicate_receipt(self, stored: Submission, best: Entry | None, racer: str) -> PushReceipt:
        """The receipt of a run already on the board, with the racer's ``best`` as read."""
        if best is None:
            raise NotAuthorized(f"{racer!r} was taken off {stored.board_id!r} by its organisers; "
                                "this run stays off it")
        return self._receipt(stored, best, duplicate=True, improved=False)

    def _receipt(self, submission: Submission, best: Entry, duplicate: bool,
                 improved: bool) -> PushReceipt:
        """The receipt, from one read of the board and its first entries: the leader, and the
        racer's rank when all who rank better are among them (else the store counts them).
        After a push that improved the board, whoever keeps its standings is handed that read."""
        keeper = self.keeper.standings_keeper if improved else None
        size = keeper.top if keeper else 1
        stored, top = self.store.front_page(best.board_id, size)
        if keeper is not None and stored is not None:
            keeper.keep(stored, top)
        if len(top) < size or (top and top[-1].score_key >= best.score_key):
            rank = 1 + sum(1 for entry in top if entry.score_key < best.score_key)
        else:
            rank = self.store.count_better(best.board_id, best.score_key) + 1
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

    def _new_claim(self, caller: Caller, alias: str, now: datetime) -> AliasClaim | None:
        """The claim a racer's push (or `PUT /me/alias`) would make, if any: None when the
        caller already holds the alias (or organises). Refused (AliasTaken) when the caller
        holds another alias, another sign-in holds it or an organiser keeps it, or the alias
        already has results on the board with no sign-in of its own (pushed by an organiser,
        imported, or pushed before sign-ins): only an organiser can give that one out."""
        if caller.organiser:
            return None
        key = racer_key(alias)
        held = self.store.alias_of(caller.principal)
        if held is not None:
            if held.racer_key != key:
                raise AliasTaken(f"you push as {held.alias!r}, not {alias!r}: an alias is claimed "
                                 "once (give `--racer` your own alias)")
            return None
        holder = self.store.alias_holder(key)
        if holder is not None:
            raise _alias_taken(holder, caller, alias)
        if self.store.history_page(key, None, None, 1).submissions:
            raise AliasTaken(f"the alias {alias!r} already has results on this board, pushed "
                             "without a sign-in: only an organiser can give it to you "
                             "(`drboard aliases assign`)")
        return AliasClaim(racer_key=key, alias=alias, principal=caller.principal, claimed_at=now)

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
        alias = valid_alias(alias)
        now = self.keeper.clock()
        claim = (AliasClaim(racer_key=racer_key(alias), alias=alias, principal=caller.principal,
                            claimed_at=now) if caller.organiser
                 else self._new_claim(caller, alias, now))
        if claim is not None:
            try:
                self.store.claim_alias(claim)
            except AliasConflict as conflict:
                raise _alias_taken(conflict.holder, caller, alias) from None
        return self.me(caller)


def valid_alias(alias: str) -> str:
    """The alias, if a racer may take it (InvalidQuery saying why not)."""
    try:
        return _ALIAS.validate_python(alias)
    except ValidationError as error:
        message = error.errors()[0]["msg"].removeprefix("Value error, ")
        raise InvalidQuery(message, detail=[{"loc": "alias", "msg": message,
                                             "type": "value_error"}]) from None


def _alias_taken(holder: AliasClaim, caller: Caller, alias: str) -> AliasTaken:
    if holder.principal == caller.principal:
        return AliasTaken(f"you push as {holder.alias!r}, not {alias!r}: an alias is claimed once")
    if holder.principal.startswith(RESERVED):
        return AliasTaken(f"the alias {alias!r} is kept by the board's organiser for its racer: "
                          "ask them to give it to your sign-in")
    return AliasTaken(f"the alias {alias!r} belongs to another racer")


def check_not_banned(board: Board, bans: EventBans, racer: str, caller: Caller) -> None:
    """Refuse a banned racer: by their alias, or by their sign-in whatever alias they push as,
    on the board or on every board of the event."""
    key = racer_key(racer)
    person = None if caller.organiser else caller.principal
    if key in board.banned or person in board.banned_principals:
        raise Banned(f"{racer!r} is banned from {board.board_id!r} by its organisers")
    if key in bans.racers or person in bans.principals:
        raise Banned(f"{racer!r} is banned from every board of this event by its organisers")


def keep_in_archive(archive: RecordArchive | None, board_id: str, submission_id: str,
                    record_json: str) -> None:
    """Keep the record (its JSON) in the archive before the push commits: a failed archive write
    stores nothing (a store error, 503). Its key is the record's content hash and the put is
    conditional, so a push refused or retried afterwards leaves at most one object no row
    refers to, and no new version."""
    if archive is not None:
        archive.put(board_id, submission_id, record_json)


def check_record_size(record: Record) -> str:
    """Every board, embedded or in the cloud, holds a record to the same bound in bytes (its
    JSON, as the assembler measures it); the record's model bounds the rest (string lengths,
    laps, runs, curve points). Returns that JSON, which the push stores and archives as it is
    (a record's JSON is written once: ~0.1 ms for a record of 27 KB)."""
    return check_record_json_size(record.model_dump_json())


def check_record_json_size(text: str) -> str:
    """``check_record_size`` of a record's JSON (``model_dump_json``'s) already written."""
    size = len(text.encode("utf-8"))
    if size > MAX_RECORD_BYTES:
        raise SubmissionTooLarge(f"the record is {size} bytes, over the {MAX_RECORD_BYTES} "
                                 "bytes a record may have")
    return text


def scored_write(record: Record, board: Board, at: datetime,
                 flags: list[str] | None = None) -> tuple[Submission, Entry]:
    """The submission and the candidate entry a record makes on a board, as of ``at``: what a
    push (or an import) hands the store. ``flags`` are for the organiser: they never move it."""
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
    for flag in flags or []:
        submission, entry = with_flag(submission, flag), with_flag(entry, flag)
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
