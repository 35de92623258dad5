"""A board's export and import: moving a board between an event laptop and the cloud; and its
recheck: every stored run indexed for copies and lookalikes, and checked against today's rules.

An import is an organiser's replay: it is never refused for a copied run or a lookalike alias;
what another racer holds is flagged for the organiser instead (both runs, for a copy).
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from datetime import datetime

from drboard_assembler.aliases import confusable_skeleton
from drboard_assembler.record import Record
from pydantic import ValidationError

from ..cursors import decode_export_cursor, decode_page_cursor, export_cursor, page_cursor
from ..errors import BoardNotFound, InvalidQuery
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import BOARD_ID_PATTERN, Board, NearRun, RunAuthor, RunPrint, Submission
from ..models.organiser_views import FlaggedRun, RecheckPage
from ..models.requests import ImportedSubmission
from ..models.transfer import (
    ExportedBoard,
    ExportedEntry,
    ExportKind,
    ExportLine,
    ExportPage,
    ImportReceipt,
    StoredSubmissionLine,
)
from ..models.views import BoardView
from ..stores.base import RecordArchive, stored_record
from ..views import board_view
from .boards import BoardKeeper, check_belongs, default_board_id, live
from .copies import (
    COPIED,
    LOOKALIKE,
    NEAR_COPY,
    NEAR_MS,
    evaluation_fingerprints,
    run_prints,
    same_laps,
)
from .loading import BulkImport
from .pushing import check_record_size, keep_in_archive, scored_write

EXPORT_ENTRIES = 500
EXPORT_SUBMISSIONS = 25  # with their records, up to 64 KiB each: a page stays under 2 MB
RECHECK_SUBMISSIONS = 25
#: A stored run that today's checks would refuse (a tightened rule): for the organiser to look at.
RULE_CHANGED = "rule-changed"


class Transfer:
    def __init__(self, keeper: BoardKeeper, archive: RecordArchive | None) -> None:
        self.keeper = keeper
        self.store = keeper.store
        self.clock = keeper.clock
        self.archive = archive

    def export_page(self, board_id: str, cursor: str | None = None) -> ExportPage:
        """One page of the board's export: the board, then its entries in rank order, then
        every submission with its record. Deleted boards export too."""
        stored = self.store.get_board(board_id)
        if stored is None:
            raise BoardNotFound(f"no board {board_id!r}")
        part, after = decode_export_cursor(cursor) if cursor else ("entries", None)
        lines: list[ExportLine] = []
        if cursor is None:
            lines.append(ExportedBoard(exported_at=self.clock(), board=stored.board))
        if part == "entries":
            entries = self.store.top(board_id, EXPORT_ENTRIES, after)
            # Models read from the store, already valid: put in the line as they are.
            lines.extend(ExportedEntry.model_construct(entry=entry) for entry in entries)
            more = len(entries) == EXPORT_ENTRIES
            next_cursor = export_cursor("entries", entries[-1].rank_key) if more else (
                export_cursor("submissions", None))
            return ExportPage(lines=lines, next_cursor=next_cursor)
        page = self.store.stored_submissions(board_id, after, EXPORT_SUBMISSIONS)
        # Each record goes out as the JSON it was stored as (it was validated when pushed).
        lines.extend(StoredSubmissionLine.of(s, raw) for s, raw in page.submissions)
        return ExportPage(lines=lines,
                          next_cursor=export_cursor("submissions", page.after) if page.after else None)

    def export_lines(self, board_id: str) -> Iterator[tuple[ExportKind, bytes]]:
        """The board's whole export as JSON lines (each ending in a newline), with each line's
        kind: the lines `export_page` gives, read straight from the store. Its entries,
        submissions and records are the JSON they were stored as (validated when they came
        in), spliced into their lines: nothing is parsed or serialised again."""
        stored = self.store.get_board(board_id)
        if stored is None:
            raise BoardNotFound(f"no board {board_id!r}")
        head = ExportedBoard(exported_at=self.clock(), board=stored.board)
        yield "board", head.model_dump_json().encode() + b"\n"
        for entry in self.store.exported_entries(board_id):
            yield "entry", b'{"kind":"entry","entry":' + entry + b"}\n"
        for submission, record in self.store.exported_submissions(board_id):
            yield "submission", (b'{"kind":"submission","submission":' + submission
                                 + b',"record":' + record + b"}\n")

    def import_board(self, board: Board, caller: Caller = LOCAL_ORGANISER) -> tuple[BoardView, bool]:
        """Create the exported board unless a board with its id exists (then that board's own
        settings stay). Returns the board and whether it was created."""
        now = self.clock()
        board = _importable(board)
        existing = self.store.get_board(board.board_id)
        if existing is not None:
            live(board.board_id, existing)
            return board_view(existing, now), False
        stored = self.store.create_board(board)
        self.keeper.audit(board.board_id, "import", caller, detail="board")
        return board_view(stored, now), stored.board == board

    def import_submission(self, board_id: str, item: ImportedSubmission,
                          caller: Caller = LOCAL_ORGANISER) -> ImportReceipt:
        """Replay one exported submission with its first submission time, scored by this
        board's rules; the window and limits do not apply. Importing twice changes nothing."""
        board = self.keeper.require(board_id).board
        record = item.record
        check_belongs(record, board)
        record_json = check_record_size(record)
        submission, entry = scored_write(record, board, item.submitted_at)
        audit = self.keeper.event(board_id, "import", caller, self.clock(), racer=record.racer,
                                  submission_id=record.submission_id)
        if self.store.get_submission(board_id, submission.racer_key, record.submission_id) is None:
            keep_in_archive(self.archive, board_id, record.submission_id, record_json)
        outcome = self.store.record_submission(submission, record_json, entry, audit=audit)
        if not outcome.duplicate:
            self._check_copies(submission, record, caller)
        return ImportReceipt(status="duplicate" if outcome.duplicate else "created",
                             board_id=board_id, submission_id=record.submission_id)

    def bulk_import(self, board: Board, caller: Caller = LOCAL_ORGANISER) -> BulkImport:
        """An import of an export into the board with ``board``'s id, in bulk: every submission
        checked and prepared before anything is written, then written a batch at a time, as
        ``import_submission`` would write them one by one (see ``loading``). The board with that
        id, if there is one, keeps its own settings; else the exported board is created."""
        board = _importable(board)
        existing = self.store.get_board(board.board_id)
        if existing is not None:
            board = live(board.board_id, existing).board
        return BulkImport(self, self.keeper, self.archive, board, caller)

    def recheck_page(self, board_id: str, cursor: str | None = None,
                     caller: Caller = LOCAL_ORGANISER) -> RecheckPage:
        """One page of a board's recheck: each stored submission's runs indexed for copies
        (their fingerprints claimed on the board where free; the earliest time of each racer
        kept), its alias's skeleton held; a run whose laps another racer pushed first, or
        pushed a few milliseconds apart, and an alias that could pass for another racer's, are
        flagged; so is a record today's checks would refuse (``rule-changed``). Run it after
        upgrading drboard or tightening a rule; running it again flags nothing new."""
        self.keeper.require(board_id)
        after = decode_page_cursor("recheck", cursor) if cursor else None
        page = self.store.stored_submissions(board_id, after, RECHECK_SUBMISSIONS)
        flagged: list[FlaggedRun] = []
        for submission, raw in page.submissions:
            flagged += self._check_copies(submission, stored_record(raw), caller)
            problem = _todays_problem(raw)
            if problem is not None:
                flagged += self._flag(submission, RULE_CHANGED, problem, caller)
        if flagged:
            self.keeper.audit(board_id, "recheck", caller,
                              detail=f"{len(flagged)} runs flagged for the organiser")
        return RecheckPage(board_id=board_id, checked=len(page.submissions), flagged=flagged,
                           next_cursor=page_cursor("recheck", page.after))

    def _check_copies(self, submission: Submission, record: Record,
                      caller: Caller) -> list[FlaggedRun]:
        """Index a stored submission for copies and lookalikes, and flag what it finds."""
        prints = run_prints(record)
        skeleton = confusable_skeleton(record.racer)
        indexed = self.store.index_submission(submission, prints, evaluation_fingerprints(record),
                                              skeleton)
        flagged: list[FlaggedRun] = []
        if indexed.skeleton_holder is not None:
            flagged += self._lookalikes(submission, skeleton, indexed.skeleton_holder, caller)
        for run in prints:
            flagged += self._copies_of(submission, run, caller)
        return flagged

    def _lookalikes(self, submission: Submission, skeleton: str, holder: str,
                    caller: Caller) -> list[FlaggedRun]:
        """Of two racers whose aliases could pass for each other's on a board, the one who pushed
        there first holds the alias's skeleton, and the other's runs are flagged."""
        board_id, racer = submission.board_id, submission.racer_key
        theirs = self.store.history(holder, board_id)
        if not theirs or self.store.history(racer, board_id)[0].submitted_at >= theirs[0].submitted_at:
            return self._flag(submission, LOOKALIKE, f"the alias could pass for {holder!r}'s on "
                              "the board", caller)
        self.store.hand_over_skeleton(board_id, skeleton, racer)
        why = f"the alias could pass for {racer!r}'s on the board"
        flagged = [run for other in theirs for run in self._flag(other, LOOKALIKE, why, caller)]
        why = f"pushed to the board before {holder!r}, whose runs are flagged instead"
        for mine in self.store.history(racer, board_id):
            self._flag(mine, LOOKALIKE, why, caller, remove=True)
        return flagged

    def _copies_of(self, submission: Submission, run: RunPrint, caller: Caller) -> list[FlaggedRun]:
        flagged: list[FlaggedRun] = []
        authors = self.store.run_authors(run.fingerprint)  # earliest first
        if len(authors) > 1:
            # The first author's earlier submission proves the run theirs: the others are
            # copies. Pushed at the same moment, nothing tells them apart: both are flagged.
            first = authors[0]
            tied = [a for a in authors if a.first_at == first.first_at]
            copies = authors[1:] if len(tied) == 1 else authors
            for author in copies:
                other = self.store.get_submission(author.board_id, author.racer_key,
                                                  author.submission_id)
                if other is not None:
                    flagged += self._flag(other, COPIED, f"the same laps as {first.racer_key!r}'s "
                                          f"on {first.board_id!r}, pushed first", caller)
        if run.laps_ms:
            mine = _first_at(authors, submission.racer_key) or submission.submitted_at
            for near in self.store.near_runs(run.lane, run.laps_ms[0], NEAR_MS):
                if (near.racer_key != submission.racer_key and near.fingerprint != run.fingerprint
                        and same_laps(run.laps_ms, near.laps_ms)):
                    flagged += self._near_copies(submission, mine, near, caller)
        return flagged

    def _near_copies(self, submission: Submission, mine: datetime, near: NearRun,
                     caller: Caller) -> list[FlaggedRun]:
        """Of two runs a few milliseconds apart, the one pushed later is the near-copy; pushed
        at the same moment, both are. (``mine``: when this submission's racer first pushed
        its run.)"""
        theirs = _first_at(self.store.run_authors(near.fingerprint), near.racer_key)
        flagged: list[FlaggedRun] = []
        if theirs is None or theirs <= mine:
            flagged += self._flag(submission, NEAR_COPY, f"laps within {NEAR_MS} ms of "
                                  f"{near.racer_key!r}'s on {near.board_id!r}", caller)
        if theirs is not None and theirs >= mine:
            other = self.store.get_submission(near.board_id, near.racer_key, near.submission_id)
            if other is not None:
                flagged += self._flag(other, NEAR_COPY, f"laps within {NEAR_MS} ms of "
                                      f"{submission.racer_key!r}'s on {submission.board_id!r}",
                                      caller)
        return flagged

    def _flag(self, submission: Submission, flag: str, why: str, caller: Caller,
              remove: bool = False) -> list[FlaggedRun]:
        """Flag a stored run for the organiser, once (an audit event says why); with ``remove``,
        take the flag off (and list nothing)."""
        if not self.store.flag_submission(submission.board_id, submission.racer_key,
                                          submission.submission_id, flag, remove=remove):
            return []
        self.keeper.audit(submission.board_id, "unflag" if remove else "flag", caller,
                          racer=submission.racer, submission_id=submission.submission_id,
                          detail=f"{flag}: {why}")
        if remove:
            return []
        return [FlaggedRun(board_id=submission.board_id, racer=submission.racer,
                           submission_id=submission.submission_id, flag=flag, why=why)]


def _first_at(authors: list[RunAuthor], racer_key: str) -> datetime | None:
    return next((author.first_at for author in authors if author.racer_key == racer_key), None)


def _importable(board: Board) -> Board:
    """The exported board as an import creates it: a track's default board if its id is that
    board's, else a named board (whose id must be one); never deleted."""
    expected = default_board_id(board.track, board.direction, board.race_type)
    kind = "default" if board.board_id == expected else "named"
    if kind == "named" and not re.match(BOARD_ID_PATTERN, board.board_id):
        raise InvalidQuery(f"{board.board_id!r} is not a board id: letters, digits, _ - .")
    return board.model_copy(update={"kind": kind, "deleted_at": None})


def _todays_problem(raw: str | bytes) -> str | None:
    """Why today's checks would refuse a stored record (its schema, bounds, lap floors, alias
    and text rules), or None."""
    try:
        Record.model_validate_json(raw)
    except ValidationError as error:
        first = error.errors()[0]
        where = ".".join(str(part) for part in first["loc"]) or "record"
        return f"{where}: {first['msg'].removeprefix('Value error, ')}"
    return None
