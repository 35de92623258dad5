"""The port the service owns. Adapters (SQLite, DynamoDB) implement it; one contract suite tests both."""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping, Sequence
from contextlib import AbstractContextManager
from datetime import datetime
from typing import TYPE_CHECKING, NamedTuple, Protocol, runtime_checkable

from drboard_assembler.record import Record

from ..models.domain import (
    AliasClaim,
    AuditEvent,
    Board,
    Entry,
    EventBans,
    NearRun,
    RacerTally,
    RunAuthor,
    RunPrint,
    Submission,
    SubmissionLimits,
    WriteOutcome,
)

if TYPE_CHECKING:  # the chat's webhooks and the seasons load with the stores' code that reads them
    from ..models.notices import Webhook
    from ..models.seasons import RoundResults, Season, SeasonLink
    from .pages import PageShelf


class StoredBoard(NamedTuple):
    board: Board
    participants: int
    # Goes up with every change to the standings or the settings, in the same write: a client
    # that saw this version has seen the board as it is.
    version: int = 0
    # Goes up with every change to the board's settings (its rules, window, limits, bans):
    # a push commits only if it is still the one it checked against.
    settings_version: int = 0
    # False only where the store knows no season ever took the board in (as a round or its
    # final): a push to it need not look for a season's final.
    maybe_in_a_season: bool = True


class RunSeen(NamedTuple):
    """Who else drove one run of a push: every racer who pushed its fingerprint, anywhere, with
    their first time, and the indexed runs of its lane whose best complete lap is within the
    near-copy tolerance (none looked for when the run has too few laps to compare)."""

    authors: list[RunAuthor]
    near: list[NearRun]


class PushReads(NamedTuple):
    """What a push reads before it writes, at once where the store can: the board (None: no
    such board), the event's bans and their version, the racer's submission of the run pushed
    (a duplicate; None: not yet on the board), the racer's entry on the board, and who else
    drove each of the push's runs (in the order of its prints)."""

    board: StoredBoard | None
    bans: EventBans
    bans_version: int
    submission: Submission | None
    entry: Entry | None
    runs: list[RunSeen]


def runs_seen(store: BoardStore, prints: Sequence[RunPrint], near_ms: int) -> list[RunSeen]:
    """Who else drove each run, read one query at a time."""
    return [RunSeen(store.run_authors(run.fingerprint),
                    store.near_runs(run.lane, run.laps_ms[0], near_ms) if run.laps_ms else [])
            for run in prints]


class LimitReached(Exception):
    """A push was refused by the board's submission limits; nothing was written."""

    def __init__(self, tally: RacerTally) -> None:
        super().__init__(f"{tally.submissions} submissions, the last at {tally.last_submitted_at}")
        self.tally = tally


class AliasConflict(Exception):
    """The alias is held by another sign-in, or the sign-in already holds another alias."""

    def __init__(self, holder: AliasClaim) -> None:
        super().__init__(f"{holder.alias!r} is held by {holder.principal}")
        self.holder = holder


class FingerprintTaken(Exception):
    """An evaluation of the pushed run is already on the board under another racer."""

    def __init__(self, racer_key: str) -> None:
        super().__init__(f"already on the board as {racer_key!r}")
        self.racer_key = racer_key


class SeasonConflict(Exception):
    """A season was not saved: a new one's id is taken, or it changed since it was read."""


class SeasonSlice(NamedTuple):
    seasons: list[Season]
    after: str | None  # where the next page starts; None on the last page


class LookalikeTaken(Exception):
    """Another racer on the board has an alias with the same confusable skeleton."""

    def __init__(self, racer_key: str) -> None:
        super().__init__(f"a lookalike of {racer_key!r} is on the board")
        self.racer_key = racer_key


class BoardChanged(Exception):
    """The board's settings or the event's bans changed since the push checked them: nothing
    was written; check again and retry."""


class RankBuild(NamedTuple):
    """How far the building of a board's rank counters got: ``done`` once the board ranks from
    its counters; ``counted`` of its ``participants`` entries counted so far."""

    done: bool
    counted: int
    participants: int


class BoardHasEntries(Exception):
    """A change that would rescore entries was refused: the board has entries."""


class AuditSlice(NamedTuple):
    events: list[AuditEvent]
    after: str | None  # where the next page starts; None on the last page


class SubmissionPage(NamedTuple):
    submissions: list[tuple[Submission, Record]]
    after: str | None  # where the next page starts; None on the last page


def stored_record(raw: str | bytes) -> Record:
    """A record read back from the board's own store, as it was stored: its shape is validated,
    but none of today's checks run again (the catalog, the lap floors, the alias and text rules,
    its content hash — see ``drboard_assembler.record.stored``), so a tightened rule never
    breaks a read; `drboard board recheck` flags the records it would refuse."""
    return Record.model_validate_json(raw, context={"stored": True})


def stored_webhook(raw: str | bytes) -> Webhook:
    """A webhook read back from the board's own store."""
    from ..models.notices import Webhook

    return Webhook.model_validate_json(raw)


class BadPageToken(ValueError):
    """A page token the store did not give out."""


def page_token(parts: Sequence[str]) -> str:
    """A store's page token: where its last page ended, as the strings of that position."""
    return json.dumps(list(parts))


def read_page_token(token: str, parts: int) -> list[str]:
    """The position a page token holds; BadPageToken when it is not one of ``parts`` strings."""
    try:
        position = json.loads(token)
    except (ValueError, RecursionError):
        raise BadPageToken("not a page token") from None
    if not (isinstance(position, list) and len(position) == parts
            and all(isinstance(part, str) for part in position)):
        raise BadPageToken("not a page token")
    return position


class AliasSlice(NamedTuple):
    claims: list[AliasClaim]
    after: str | None  # where the next page starts; None on the last page


class Indexed(NamedTuple):
    """What indexing a stored submission found held by other racers on its board: each
    fingerprint's holder, and the holder of its racer's confusable skeleton (None: free)."""

    fingerprint_holders: dict[str, str]
    skeleton_holder: str | None


class StoredSubmissionPage(NamedTuple):
    submissions: list[tuple[Submission, str | bytes]]  # each with its record's JSON as stored
    after: str | None  # where the next page starts; None on the last page


class ImportedRow(NamedTuple):
    """One submission of a bulk import as the store writes it: its JSON, its record's JSON
    and the entry it makes, with the keys they are found by (see ``BoardStore.import_batch``)."""

    submission_id: str
    racer_key: str
    submitted_at: str  # ranking.timestamp of the submission's time
    score_key: str
    rank_key: str
    submission: str  # the Submission's JSON
    entry: str  # the Entry's JSON: the racer's entry if it is their best
    record: str  # the Record's JSON


class IndexedRun(NamedTuple):
    """A run of an imported submission, indexed for every board (copies and near-copies)."""

    fingerprint: str
    lane: str
    laps_ms: tuple[int, ...] | None
    racer_key: str
    submitted_at: str  # ranking.timestamp
    submission_id: str


class ImportBatch(NamedTuple):
    """What one batch of a bulk import writes, in one transaction."""

    rows: list[ImportedRow]  # in import order
    fingerprints: list[tuple[str, str]]  # (fingerprint, racer key): claimed on the board where free
    skeletons: list[tuple[str, str]]  # (confusable skeleton, racer key): held where free
    runs: list[IndexedRun]
    audit: list[AuditEvent]


class ImportWritten(NamedTuple):
    created: int  # submissions stored (those already on the board are left as they are)
    improved: int  # entries made or bettered


@runtime_checkable
class HeldWrites(Protocol):
    """A store that can hold a whole import in one transaction (the embedded board)."""

    def held_writes(self) -> AbstractContextManager[None]:
        """Every write the calling thread makes in the block, in one transaction: committed
        when the block ends, none of them kept when it raises."""


def new_rows(rows: Sequence[ImportedRow], present: set[str]) -> list[ImportedRow]:
    """The rows whose submission is not on the board yet, each submission once."""
    seen = set(present)
    kept = []
    for row in rows:
        if row.submission_id not in seen:
            seen.add(row.submission_id)
            kept.append(row)
    return kept


class BoardSlice(NamedTuple):
    boards: list[StoredBoard]
    after: str | None  # where the next page starts; None on the last page


class HistorySlice(NamedTuple):
    submissions: list[Submission]
    after: str | None  # where the next page starts; None on the last page


class NoticeStore(Protocol):
    """Where announcements keep their webhooks and their sent markers (both stores have it)."""

    def put_webhook(self, webhook: Webhook) -> None:
        """Add (or replace) a webhook of its target."""

    def webhooks(self, target_key: str) -> list[Webhook]:
        """The target's webhooks, oldest first."""

    def all_webhooks(self) -> list[Webhook]:
        """Every target's webhooks (what a check of the boards' windows looks at)."""

    def delete_webhook(self, target_key: str, webhook_id: str) -> Webhook | None:
        """Remove a webhook; the one removed, or None."""

    def note_delivery(self, target_key: str, webhook_id: str, at: datetime,
                      error: str | None) -> None:
        """Keep how the webhook's last delivery went: sent at ``at``, or failed with ``error``."""

    def claim_notice(self, notice_id: str, webhook_id: str, now: datetime, lease_s: int) -> bool:
        """Atomically take the right to send the event to the webhook: True unless it was sent
        already, or another sender took it less than ``lease_s`` ago."""

    def finish_notice(self, notice_id: str, webhook_id: str, sent: bool) -> None:
        """Mark a claimed notice sent (never sent again), or failed (the next try may claim it)."""


def claimable(state: str, lease_until: str, now: datetime) -> bool:
    """Whether a notice may be claimed: it failed, or its sender's lease ran out (a sender that
    died after claiming it); never once sent."""
    from .. import ranking

    if state == "sent":
        return False
    return state == "failed" or ranking.parse_timestamp(lease_until) <= now


def delivered(webhook: Webhook, at: datetime, error: str | None) -> Webhook:
    """The webhook with its last delivery noted: sent at ``at`` (its last error cleared), or
    failed at ``at`` with ``error``."""
    from ..models.notices import MAX_ERROR_CHARS

    if error is None:
        return webhook.model_copy(update={"last_sent_at": at, "last_error": None, "last_error_at": None})
    return webhook.model_copy(update={"last_error": error[:MAX_ERROR_CHARS], "last_error_at": at})


class BoardStore(NoticeStore, Protocol):
    @property
    def pages(self) -> PageShelf | None:
        """Where the store keeps boards' pages as the bytes that answer them (None: it keeps
        none; the processes that read its boards keep their own)."""

    def get_board(self, board_id: str) -> StoredBoard | None:
        """The board and its number of racers, or None."""

    def board_version(self, board_id: str) -> int | None:
        """The board's version alone (None: no such board), in the store's cheapest read: what a
        kept copy of its standings is checked against (see ``routes.standings``)."""

    def create_board(self, board: Board) -> StoredBoard:
        """Create the board unless it exists; return what is stored."""

    def update_board(self, board: Board, *, only_if_empty: bool = False) -> StoredBoard:
        """Replace an existing board's settings (its id stays) and bump its version. With
        ``only_if_empty``, raise BoardHasEntries when the board has any entry."""

    def list_boards(self) -> list[StoredBoard]:
        """Every board, deleted ones included, ordered by id."""

    def boards_page(self, after: str | None, limit: int) -> BoardSlice:
        """Up to ``limit`` boards, deleted ones included, by id, after the store's page token
        ``after`` (ValueError when it is not one the store gave out)."""

    def record_submission(self, submission: Submission, record_json: str, entry: Entry,
                          limits: SubmissionLimits | None = None,
                          fingerprints: Sequence[str] = (),
                          audit: AuditEvent | None = None, *,
                          runs: Sequence[RunPrint] = (), claim: AliasClaim | None = None,
                          skeleton: str | None = None) -> WriteOutcome:
        """Atomically: store the submission, with its record as ``record_json`` holds it (the
        record's JSON, as the service wrote it once), unless its id is already on the board (a
        duplicate, which changes nothing and is never refused), and make ``entry`` the racer's entry if it
        has a strictly lower rank key than the current one (a better score, or an equal score
        achieved earlier); a changed entry bumps the board's version in the same write. With
        ``limits``, a new submission is refused with LimitReached, and
        nothing written, when the racer's last one is under ``cooldown_s`` old or they have
        reached ``max_submissions``. Each of ``fingerprints`` (its evaluations' content) is
        claimed on the board for the racer: one already held by another racer refuses the push
        with FingerprintTaken, nothing written. ``audit`` is appended in the same transaction.
        Concurrent calls never lose a submission or a best, and never exceed a limit.

        In the same write, for a new submission: each of ``runs`` is indexed for every board
        (the racer's first time with its fingerprint, and its laps for near-copies); ``claim``
        binds the alias to its sign-in (AliasConflict when another holds either, nothing
        written); ``skeleton`` (the alias's confusable skeleton) is held on the board for the
        racer (LookalikeTaken when another racer holds it); and when ``limits`` carries the
        board's settings version or the event's bans version, either having moved raises
        BoardChanged, nothing written."""

    def get_submission(self, board_id: str, racer_key: str, submission_id: str) -> Submission | None:
        """One submission of the racer on the board."""

    def push_reads(self, board_id: str, racer_key: str, submission_id: str,
                   prints: Sequence[RunPrint], near_ms: int) -> PushReads:
        """A push's first reads (see ``PushReads``), at once where the store can; ``near_ms``
        is the near-copy tolerance the runs' lanes are read with."""

    def tally(self, board_id: str, racer_key: str) -> RacerTally:
        """How many submissions the racer made on the board, and when the last one was."""

    def submissions(self, board_id: str, after: str | None, limit: int) -> SubmissionPage:
        """Up to ``limit`` of the board's submissions with their records, in a stable order,
        starting after the page token ``after``."""

    def stored_submissions(self, board_id: str, after: str | None, limit: int) -> StoredSubmissionPage:
        """As ``submissions``, with each record the JSON it was stored as (not parsed): what an
        export writes out."""

    def exported_entries(self, board_id: str) -> Iterator[bytes]:
        """Every entry of the board in rank-key order, each the JSON it is stored as (UTF-8,
        nothing parsed): what `drboard export` writes out, read a page at a time."""

    def exported_submissions(self, board_id: str) -> Iterator[tuple[bytes, bytes]]:
        """Every submission of the board in a stable order with its record, each the JSON it
        is stored as (UTF-8, nothing parsed), read a page at a time."""

    def top(self, board_id: str, limit: int, after: str | None = None) -> list[Entry]:
        """Up to ``limit`` entries in rank-key order, starting after the rank key ``after``."""

    def front_page(self, board_id: str, limit: int) -> tuple[StoredBoard | None, list[Entry]]:
        """The board and its first ``limit`` entries (what most reads want), in as few reads
        as the store can."""

    def get_entry(self, board_id: str, racer_key: str) -> Entry | None:
        """The racer's entry on the board."""

    def count_better(self, board_id: str, score_key: str) -> int:
        """How many entries have a score key strictly lower than ``score_key``."""

    def history(self, racer_key: str, board_id: str | None = None) -> list[Submission]:
        """The racer's submissions, oldest first, on one board or all."""

    def history_page(self, racer_key: str, board_id: str | None, after: str | None,
                     limit: int) -> HistorySlice:
        """Up to ``limit`` of the racer's submissions, oldest first (on one board or all),
        after the store's page token ``after`` (BadPageToken when it is not one it gave out)."""

    def get_record(self, board_id: str, submission_id: str) -> Record | None:
        """The full record of one submission."""

    # ---- moderation and audit ---------------------------------------------------------------

    def remove_entry(self, board_id: str, racer_key: str) -> Entry | None:
        """Take the racer's entry off the board (its submissions stay), bumping the board's
        version; the removed entry."""

    def build_rank_counters(self, board_id: str, budget_s: float | None = None) -> RankBuild:
        """Count the entries of a board from before the rank counters into its counters, a
        batch at a time for up to ``budget_s`` seconds (None: to the end); a later call goes on
        where this one stopped. A board that has its counters is done at once."""
        ...

    def restore_entry(self, entry: Entry) -> None:
        """Put back an entry for a racer who has none on the board, bumping its version."""

    def append_audit(self, event: AuditEvent) -> None:
        """Add one event to its board's audit trail (append-only)."""

    def audit(self, board_id: str, after: str | None, limit: int) -> AuditSlice:
        """Up to ``limit`` of the board's audit events in time order, after the token ``after``."""

    # ---- copies and lookalikes ----------------------------------------------------------------

    def run_authors(self, fingerprint: str) -> list[RunAuthor]:
        """Every racer who pushed a run with this fingerprint, on any board, with their first time."""

    def near_runs(self, lane: str, best_ms: int, tolerance_ms: int) -> list[NearRun]:
        """The indexed runs of the lane whose best complete lap is within ``tolerance_ms``."""

    def fingerprint_holder(self, board_id: str, fingerprint: str) -> str | None:
        """The racer key holding the fingerprint on the board."""

    def hand_over_fingerprint(self, board_id: str, fingerprint: str, racer_key: str) -> None:
        """Give the fingerprint on the board to ``racer_key`` (its first author)."""

    def hand_over_skeleton(self, board_id: str, skeleton: str, racer_key: str) -> None:
        """Give the confusable skeleton on the board to ``racer_key`` (who pushed there first)."""

    def flag_submission(self, board_id: str, racer_key: str, submission_id: str,
                        flag: str, remove: bool = False) -> bool:
        """Add ``flag`` to the submission's score (with ``remove``: take it off), and to the
        racer's entry when it is that submission (bumping the board's version); whether
        anything changed."""

    def index_submission(self, submission: Submission, runs: Sequence[RunPrint],
                         fingerprints: Sequence[str], skeleton: str | None) -> Indexed:
        """Index a submission stored before these indexes (a board's recheck): its runs for
        every board (keeping the earliest time of each racer), each fingerprint and the
        skeleton claimed on its board where free. What other racers hold is returned."""

    # ---- bulk import ------------------------------------------------------------------------

    def present_submissions(self, board_id: str, keys: Sequence[tuple[str, str]]) -> set[str]:
        """Which of these (racer key, submission id) are on the board: their submission ids."""

    def lane_runs(self, lane: str) -> list[NearRun]:
        """Every indexed run of the lane, on every board, by best lap, then fingerprint, racer
        and board (what ``near_runs`` reads a range of)."""

    def authors_of(self, fingerprints: Sequence[str]) -> dict[str, list[RunAuthor]]:
        """``run_authors`` of each fingerprint (earliest first), those with none left out."""

    def holders(self, board_id: str, fingerprints: Sequence[str],
                skeletons: Sequence[str]) -> tuple[dict[str, str], dict[str, str]]:
        """Who holds each of these fingerprints, and each of these skeletons, on the board (by
        racer key; those no one holds left out)."""

    def import_batch(self, board_id: str, batch: ImportBatch) -> ImportWritten:
        """Write a batch of imported submissions, atomically (a store that cannot hold a batch
        in one transaction commits it in parts, each whole, in order; each part's submissions
        with their entries, tallies and rank counts): for each row in order, as
        ``record_submission`` without limits would, the submission and its record unless its
        id is on the board already (then the row changes nothing), and its entry if the racer
        has none or it has a strictly lower rank key (counts, participants and the board's
        version moved to match); then each of ``fingerprints`` and ``skeletons`` claimed for
        its racer where no racer holds it, ``runs`` indexed as ``index_submission`` indexes
        them, and ``audit`` appended (an event already there is left as it is: the same batch
        written twice changes nothing). KeyError when there is no such board."""

    # ---- event-wide bans --------------------------------------------------------------------

    def event_bans(self) -> tuple[EventBans, int]:
        """The event's bans and their version (0 before any)."""

    def save_event_bans(self, bans: EventBans, version: int) -> int:
        """Replace the event's bans if their version is still ``version`` (else BoardChanged);
        the new version."""

    # ---- aliases ----------------------------------------------------------------------------

    def assign_alias(self, claim: AliasClaim) -> AliasClaim | None:
        """Bind the alias to ``claim.principal`` whoever held it (an organiser's hand): the
        alias's previous claim, if any, and any other alias the principal held, are replaced.
        Returns the previous claim of the alias."""

    def release_alias(self, racer_key: str) -> AliasClaim | None:
        """Unbind the alias from its sign-in; the claim removed, if any."""

    def aliases(self, after: str | None, limit: int) -> AliasSlice:
        """Up to ``limit`` alias claims by racer key, after the store's page token ``after``."""

    def claim_alias(self, claim: AliasClaim) -> AliasClaim:
        """Bind the alias to the sign-in, atomically: unless either is bound to another (then
        AliasConflict with the holder). Claiming one's own alias again returns the claim."""

    def alias_of(self, principal: str) -> AliasClaim | None:
        """The alias a sign-in holds."""

    def alias_holder(self, racer_key: str) -> AliasClaim | None:
        """Who holds an alias."""

    # ---- seasons ----------------------------------------------------------------------------

    def get_season(self, season_id: str) -> Season | None:
        """The season, or None."""

    def save_season(self, season: Season, links: Mapping[str, SeasonLink | None],
                    forget: Sequence[str] = ()) -> Season:
        """Write the season if the stored one is at ``season.version - 1`` (a season at version
        1 is new: written only if its id is free), else SeasonConflict and nothing written. In
        the same write, each board of ``links`` gets that link to the season (None: loses it)
        and its version goes up (its page shows the link), and the season's kept results of
        the boards in ``forget`` (rounds it no longer has) go."""

    def seasons_page(self, after: str | None, limit: int) -> SeasonSlice:
        """Up to ``limit`` seasons by id, after the store's page token ``after``."""

    def season_links(self, board_id: str) -> list[SeasonLink]:
        """The seasons the board belongs to (as a round or a final), by season id."""

    def boards_by_id(self, board_ids: Sequence[str]) -> dict[str, StoredBoard]:
        """The boards of these ids that exist, read together."""

    def round_results(self, season_id: str) -> dict[str, RoundResults]:
        """The results the season keeps of its rounds, by board id."""

    def keep_round_results(self, season_id: str, results: RoundResults) -> None:
        """Keep a round's results for the season, unless it keeps them as of a later version
        of the board already (a store may also decline results too big for it to keep: its
        views then read the round again)."""


class RecordArchive(Protocol):
    def put(self, board_id: str, submission_id: str, record_json: str) -> None:
        """Keep the raw record of a submission (its JSON, S3 in the cloud), before the push
        commits; a failure raises a store error and the push stores nothing."""
