"""A board's export imported in bulk (`drboard import` on the embedded board): every exported
submission is checked and prepared once — what importing it writes —, and the prepared
submissions are written a batch at a time. Where the store can hold a whole import in one
transaction (``whole``: the embedded board), the batches are written in it as the lines are
checked, and nothing is kept unless every line passes; elsewhere every submission is checked
before anything is written, and each batch is a transaction of its own.

A batch writes what replaying its submissions one by one would (``Transfer.import_submission``):
each submission not on the board yet, scored by the board's rules, the racer's entry when it is
their best, an ``import`` event in the audit trail, its runs indexed for every board, its
fingerprints and its alias's skeleton claimed on the board where free; and, as an import is an
organiser's replay, never a refusal for a copied run or a lookalike alias: what replaying would
flag for the organiser is flagged (both runs of a copy, a near-copy, a lookalike). A batch reads
what the boards hold of its submissions in a few reads (those already on the board, their runs'
authors, the holders of their fingerprints and skeletons), replays its submissions in memory, in
order, from there, and writes the outcome at once. The runs a near-copy is looked for among are
read once per lane (track, direction, race type), when the import first meets it, and kept with
the import's own as it writes them: a run another racer pushes during the import is compared
with the import's by that push (which flags its own run, where a replay would have flagged the
imported one).

What is checked of each submission here: that it belongs on the board, that its record is
within the record's bound in bytes, and that its submission id is its content's hash (the
record's schema and bounds are the caller's to check, as for every record the service takes).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from datetime import datetime
from typing import TYPE_CHECKING, NamedTuple

from drboard_assembler.aliases import confusable_skeleton
from drboard_assembler.limits import MAX_RECORD_BYTES
from drboard_assembler.record import Record, content_hash, json_content_hash

from .. import ranking
from ..errors import InvalidSubmission, StoreBusy
from ..identity import Caller
from ..models.domain import AuditEvent, Board, Entry, NearRun, Submission, with_flag
from ..models.requests import ImportedSubmission
from ..models.views import BoardView
from ..stores.base import HeldWrites, ImportBatch, ImportedRow, IndexedRun, RecordArchive
from .boards import BoardKeeper, check_belongs
from .copies import COPIED, LOOKALIKE, NEAR_COPY, NEAR_MS, run_prints, same_laps
from .pushing import check_record_json_size, keep_in_archive, scored_write

if TYPE_CHECKING:
    from .transfer import Transfer

#: A run of a prepared submission: its fingerprint, its lane, and its complete laps' times,
#: sorted, when it has enough of them to be compared (else None).
Run = tuple[str, str, tuple[int, ...] | None]
#: A submission, by where it is: (board id, racer key, submission id).
Where = tuple[str, str, str]
#: An indexed run: (fingerprint, racer key, board id, submission id, sorted complete laps).
NearTuple = tuple[str, str, str, str, tuple[int, ...]]


class PreparedSubmission(NamedTuple):
    """An exported submission checked for its board, and what importing it writes."""

    row: ImportedRow
    racer: str
    runs: tuple[Run, ...]
    fingerprints: tuple[str, ...]  # of its evaluations that completed a lap: claimed on the board
    skeleton: str  # its alias's confusable skeleton: held on the board


class ImportTally(NamedTuple):
    created: int
    duplicates: int


def prepare_submission(board: Board, record: Record, submitted_at: datetime,
                       record_json: str | None = None) -> PreparedSubmission:
    """Check an exported submission (its record, first submitted at ``submitted_at``) for
    ``board`` (BoardMismatch, SubmissionTooLarge, InvalidSubmission when its id is not its
    content's hash) and prepare what importing it writes: reads and writes nothing. The board
    stores the record as ``record_json``, the JSON it was read from, when given and within the
    record's bound (else as the record writes itself out)."""
    check_belongs(record, board)
    given = record_json if record_json is not None and len(record_json) <= MAX_RECORD_BYTES else None
    stored = check_record_json_size(given or record.model_dump_json())
    # The hash of the JSON stored, as it is; the record's own where that JSON writes a value
    # otherwise than the record does (the record's content is what its id names).
    if ((given is None or json_content_hash(given) != record.submission_id)
            and content_hash(record) != record.submission_id):
        raise InvalidSubmission("the record's submission_id does not match its content",
                                detail=[{"loc": "record.submission_id", "type": "value_error",
                                         "msg": "does not match the record's content"}])
    submission, entry = scored_write(record, board, submitted_at)
    prints = run_prints(record)
    return PreparedSubmission(
        row=ImportedRow(submission_id=record.submission_id, racer_key=submission.racer_key,
                        submitted_at=ranking.timestamp(submitted_at),
                        score_key=entry.score_key, rank_key=entry.rank_key,
                        submission=submission.model_dump_json(), entry=entry.model_dump_json(),
                        record=stored),
        racer=record.racer,
        runs=tuple((p.fingerprint, p.lane, tuple(p.laps_ms) if p.laps_ms else None)
                   for p in prints),
        fingerprints=tuple(sorted({p.fingerprint for p in prints})),
        skeleton=confusable_skeleton(record.racer))


class BulkImport:
    """One import of an export into one board: ``prepare`` every submission (nothing is
    written), then ``open`` the board and ``load`` the prepared submissions batch by batch."""

    def __init__(self, transfer: Transfer, keeper: BoardKeeper, archive: RecordArchive | None,
                 board: Board, caller: Caller) -> None:
        self.transfer = transfer
        self.keeper = keeper
        self.store = keeper.store
        self.archive = archive
        #: The board imported into: the one with the export's (or the chosen) id if it exists,
        #: with its own settings; else the exported board, which ``open`` creates.
        self.board = board
        self.caller = caller
        self._lanes: dict[str, _Lane] = {}

    def prepare(self, item: ImportedSubmission) -> PreparedSubmission:
        """Check an exported submission for the board and prepare what importing it writes
        (``prepare_submission``); the record is archived too, where the board archives."""
        prepared = prepare_submission(self.board, item.record, item.submitted_at)
        self.keep(prepared)
        return prepared

    def keep(self, prepared: PreparedSubmission) -> None:
        """Archive a prepared submission's record as the board stores it, where the board
        archives records."""
        keep_in_archive(self.archive, self.board.board_id, prepared.row.submission_id,
                        prepared.row.record)

    @property
    def holds_whole(self) -> bool:
        """Whether the store can hold the whole import in one transaction (``whole``)."""
        return isinstance(self.store, HeldWrites)

    @contextmanager
    def whole(self) -> Iterator[None]:
        """Every write of the import made in the block (``open``, ``load``) in one transaction:
        committed when the block ends, none of them kept when it raises."""
        if not isinstance(self.store, HeldWrites):
            raise TypeError("the store cannot hold an import in one transaction")
        with self.store.held_writes():
            yield

    def open(self) -> tuple[BoardView, bool]:
        """Create the board unless it exists (as ``import_board``); whether it was created."""
        view, created = self.transfer.import_board(self.board, self.caller)
        self._check_rules()
        return view, created

    def load(self, batch: Sequence[PreparedSubmission]) -> ImportTally:
        """Write a batch of prepared submissions, in one transaction (see the module)."""
        self._check_rules()
        replay = _Replay(self, batch)
        written = self.store.import_batch(self.board.board_id, replay.batch())
        replay.flag_the_others()
        return ImportTally(created=written.created, duplicates=len(batch) - written.created)

    def lane(self, lane: str) -> _Lane:
        """The runs of a lane this import compares with: those indexed when it first met the
        lane, then its own as it writes them."""
        if lane not in self._lanes:
            self._lanes[lane] = _Lane(self.store.lane_runs(lane))
        return self._lanes[lane]

    def _check_rules(self) -> None:
        stored = self.keeper.require(self.board.board_id).board
        if stored.rules != self.board.rules:
            raise StoreBusy(f"the rules of {self.board.board_id!r} changed while the export was "
                            "checked; import it again")


#: The side of a cell of a lane's runs, in milliseconds: the runs whose best and slowest laps
#: are each within NEAR_MS of a run's lie in at most two cells each way.
CELL_MS = 2 * NEAR_MS + 1


class _Lane:
    """The indexed runs of a lane, each once per best lap, fingerprint, racer and board, as
    (fingerprint, racer key, board id, submission id, sorted complete laps), by the cell of
    their best and slowest laps."""

    def __init__(self, runs: Sequence[NearRun]) -> None:
        self.cells: dict[tuple[int, int], list[NearTuple]] = {}
        self.keys: set[tuple[int, str, str, str]] = set()
        for run in runs:
            self.add((run.fingerprint, run.racer_key, run.board_id, run.submission_id,
                      tuple(run.laps_ms)))

    def add(self, run: NearTuple) -> None:
        laps = run[4]
        key = (laps[0], run[0], run[1], run[2])
        if key not in self.keys:
            self.keys.add(key)
            self.cells.setdefault((laps[0] // CELL_MS, laps[-1] // CELL_MS), []).append(run)

    def near(self, fingerprint: str, racer_key: str, laps: tuple[int, ...]) -> list[NearTuple]:
        """Other racers' runs whose laps are each within NEAR_MS of these, in the order the
        store reads them (by best lap, fingerprint, racer and board)."""
        best, slowest = laps[0], laps[-1]
        rows, columns = _cells_near(best), _cells_near(slowest)
        found = [run for row in rows for column in columns
                 for run in self.cells.get((row, column), ())
                 if abs(run[4][0] - best) <= NEAR_MS and abs(run[4][-1] - slowest) <= NEAR_MS
                 and len(run[4]) == len(laps) and run[1] != racer_key and run[0] != fingerprint
                 and same_laps(list(laps), list(run[4]))]
        return sorted(found, key=lambda run: (run[4][0], run[0], run[1], run[2]))


def _cells_near(ms: int) -> tuple[int, ...]:
    """The cells of the times within NEAR_MS of ``ms``."""
    low, high = (ms - NEAR_MS) // CELL_MS, (ms + NEAR_MS) // CELL_MS
    return (low,) if low == high else (low, high)


class _Replay:
    """A batch replayed in memory, in order, from what the boards hold when it starts."""

    def __init__(self, load: BulkImport, batch: Sequence[PreparedSubmission]) -> None:
        self.load = load
        self.board_id = board_id = load.board.board_id
        store = load.store
        self.present = store.present_submissions(
            board_id, [(p.row.racer_key, p.row.submission_id) for p in batch])
        #: Each fingerprint's authors: racer key -> (first time, board id, submission id).
        self.authors = {fingerprint: {a.racer_key: (ranking.timestamp(a.first_at), a.board_id,
                                                    a.submission_id) for a in authors}
                        for fingerprint, authors in store.authors_of(
                            sorted({run[0] for p in batch for run in p.runs})).items()}
        self.fingerprint_holders, self.skeleton_holders = store.holders(
            board_id, sorted({f for p in batch for f in p.fingerprints}),
            sorted({p.skeleton for p in batch}))
        self.flags: dict[Where, list[str]] = {}  # flags added, in order, by where
        self.written: dict[str, PreparedSubmission] = {}
        self.claims: list[tuple[str, str]] = []
        self.held: list[tuple[str, str]] = []
        self.handed: list[tuple[str, str]] = []  # skeletons given to who pushed first
        self.runs: list[IndexedRun] = []
        self.audit: list[AuditEvent] = []
        #: Flags on other batches' or boards' runs, to add (or to take off: True), in order.
        self.later: list[tuple[Where, str, str, bool]] = []
        for prepared in batch:
            row = prepared.row
            if row.submission_id not in self.present and row.submission_id not in self.written:
                self.written[row.submission_id] = prepared
                self._import(prepared)

    def _import(self, prepared: PreparedSubmission) -> None:
        row = prepared.row
        racer_key, submission_id = row.racer_key, row.submission_id
        self._event("import", prepared.racer, submission_id)
        for fingerprint, lane, laps in prepared.runs:
            self._index(row, fingerprint, lane, laps)
        for fingerprint in prepared.fingerprints:
            if fingerprint not in self.fingerprint_holders:
                self.fingerprint_holders[fingerprint] = racer_key
                self.claims.append((fingerprint, racer_key))
        holder = self.skeleton_holders.get(prepared.skeleton)
        if holder is None:
            self.skeleton_holders[prepared.skeleton] = racer_key
            self.held.append((prepared.skeleton, racer_key))
        elif holder != racer_key:
            self._lookalikes(prepared, holder)
        for fingerprint, lane, laps in prepared.runs:  # its copies and near-copies
            if len(self.authors[fingerprint]) > 1:
                self._flag_copies(self.authors[fingerprint])
            for near in self.load.lane(lane).near(fingerprint, racer_key, laps) if laps else ():
                self._flag_near_copy(prepared, fingerprint, near)

    def _index(self, row: ImportedRow, fingerprint: str, lane: str,
               laps: tuple[int, ...] | None) -> None:
        """The run indexed as the store indexes it: its racer's earliest time with it kept,
        and its laps for near-copies (once per racer and board)."""
        self.runs.append(IndexedRun(fingerprint, lane, laps, row.racer_key, row.submitted_at,
                                    row.submission_id))
        authors = self.authors.get(fingerprint)
        if authors is None:
            authors = self.authors[fingerprint] = {}
        mine = authors.get(row.racer_key)
        # Timestamps of one fixed width, in UTC: as text, they sort in time order.
        if mine is None or row.submitted_at < mine[0]:
            authors[row.racer_key] = (row.submitted_at, self.board_id, row.submission_id)
        if laps:
            self.load.lane(lane).add((fingerprint, row.racer_key, self.board_id,
                                      row.submission_id, laps))

    def _flag_copies(self, authors: dict[str, tuple[str, str, str]]) -> None:
        """As ``Transfer._copies_of``: the copies of a run of several authors, every author
        but its first (all of them when the first are tied)."""
        ordered = sorted(authors.items(), key=lambda author: author[1][0])
        first_racer, (first_at, first_board, _) = ordered[0]
        tied = [racer for racer, (at, _, _) in ordered if at == first_at]
        for racer, (_, board_id, submission_id) in ordered[1:] if len(tied) == 1 else ordered:
            self._flag((board_id, racer, submission_id), None, COPIED,
                       f"the same laps as {first_racer!r}'s on {first_board!r}, pushed first")

    def _lookalikes(self, prepared: PreparedSubmission, holder: str) -> None:
        """As ``Transfer._lookalikes``: of two racers whose aliases could pass for each other's
        on the board, the one who pushed there first holds the skeleton, and the other's runs
        are flagged."""
        row = prepared.row
        theirs = self._on_board(holder)
        if not theirs or self._on_board(row.racer_key)[0][0] >= theirs[0][0]:
            self._flag((self.board_id, row.racer_key, row.submission_id), prepared.racer,
                       LOOKALIKE, f"the alias could pass for {holder!r}'s on the board")
            return
        self.skeleton_holders[prepared.skeleton] = row.racer_key
        self.handed.append((prepared.skeleton, row.racer_key))
        why = f"the alias could pass for {row.racer_key!r}'s on the board"
        for _, submission_id, racer in theirs:
            self._flag((self.board_id, holder, submission_id), racer, LOOKALIKE, why)
        why = f"pushed to the board before {holder!r}, whose runs are flagged instead"
        for _, submission_id, racer in self._on_board(row.racer_key):
            self._unflag((self.board_id, row.racer_key, submission_id), racer, LOOKALIKE, why)

    def _on_board(self, racer_key: str) -> list[tuple[str, str, str]]:
        """The racer's submissions on the board, stored or of this batch so far, oldest first:
        (time as a timestamp, submission id, alias)."""
        stored = [(ranking.timestamp(s.submitted_at), s.submission_id, s.racer)
                  for s in self.load.store.history(racer_key, self.board_id)]
        return sorted(stored + [(p.row.submitted_at, p.row.submission_id, p.racer)
                                for p in self.written.values() if p.row.racer_key == racer_key])

    def _flag_near_copy(self, prepared: PreparedSubmission, fingerprint: str,
                        near: NearTuple) -> None:
        """As ``Transfer._near_copies``: of two runs a few milliseconds apart, the one pushed
        later is the near-copy (both, pushed at the same moment), whatever the file's order."""
        row = prepared.row
        mine = self.authors[fingerprint][row.racer_key][0]
        theirs = self._first_at(near[0], near[1])
        if theirs is None or theirs <= mine:
            self._flag((self.board_id, row.racer_key, row.submission_id), prepared.racer,
                       NEAR_COPY, f"laps within {NEAR_MS} ms of {near[1]!r}'s on {near[2]!r}")
        if theirs is not None and theirs >= mine:
            self._flag((near[2], near[1], near[3]), None, NEAR_COPY,
                       f"laps within {NEAR_MS} ms of {row.racer_key!r}'s on {self.board_id!r}")

    def _first_at(self, fingerprint: str, racer_key: str) -> str | None:
        """When the racer first pushed the run (as a timestamp), or None if unknown."""
        authors = self.authors.get(fingerprint)
        if authors is None:  # a run of no submission of this batch: the store's are current
            authors = {a.racer_key: (ranking.timestamp(a.first_at), a.board_id, a.submission_id)
                       for a in self.load.store.authors_of([fingerprint]).get(fingerprint, ())}
        mine = authors.get(racer_key)
        return mine[0] if mine else None

    def _flag(self, where: Where, racer: str | None, flag: str, why: str) -> None:
        """Flag a run once: this batch's when it writes it, another's after the batch."""
        flags = self.flags.setdefault(where, [])
        if flag in flags:
            return
        flags.append(flag)
        board_id, _, submission_id = where
        if board_id == self.board_id and submission_id in self.written:
            self._event("flag", racer or self.written[submission_id].racer, submission_id,
                        f"{flag}: {why}")
        else:
            self.later.append((where, flag, why, False))

    def _unflag(self, where: Where, racer: str, flag: str, why: str) -> None:
        """Take a flag off a run: this batch's as it writes it, another's after the batch."""
        flags = self.flags.get(where, [])
        flagged_here = flag in flags
        if flagged_here:
            flags.remove(flag)
        if where[0] == self.board_id and where[2] in self.written:
            if flagged_here:
                self._event("unflag", racer, where[2], f"{flag}: {why}")
        else:
            self.later.append((where, flag, why, True))

    def _event(self, action: str, racer: str, submission_id: str, detail: str = "") -> None:
        keeper = self.load.keeper
        self.audit.append(keeper.event(self.board_id, action, self.load.caller,  # type: ignore[arg-type]
                                       keeper.clock(), racer=racer, submission_id=submission_id,
                                       detail=detail))

    def batch(self) -> ImportBatch:
        return ImportBatch(rows=[self._flagged(p.row) for p in self.written.values()],
                           fingerprints=self.claims, skeletons=self.held, runs=self.runs,
                           audit=self.audit)

    def _flagged(self, row: ImportedRow) -> ImportedRow:
        flags = self.flags.get((self.board_id, row.racer_key, row.submission_id))
        if not flags:
            return row
        submission = Submission.model_validate_json(row.submission)
        entry = Entry.model_validate_json(row.entry)
        for flag in flags:
            submission, entry = with_flag(submission, flag), with_flag(entry, flag)
        return row._replace(submission=submission.model_dump_json(), entry=entry.model_dump_json())

    def flag_the_others(self) -> None:
        """Flag the runs of other batches and other boards this batch showed to be copies (or
        lookalikes), and give the skeletons it found held by a later racer to the first."""
        store, keeper = self.load.store, self.load.keeper
        for skeleton, racer_key in self.handed:
            store.hand_over_skeleton(self.board_id, skeleton, racer_key)
        for (board_id, racer_key, submission_id), flag, why, remove in self.later:
            other = store.get_submission(board_id, racer_key, submission_id)
            if other is not None and store.flag_submission(board_id, racer_key, submission_id,
                                                           flag, remove=remove):
                keeper.audit(board_id, "unflag" if remove else "flag", self.load.caller,
                             racer=other.racer, submission_id=submission_id,
                             detail=f"{flag}: {why}")
