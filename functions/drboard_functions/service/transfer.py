"""A board's export and import: moving a board between an event laptop and the cloud."""

from __future__ import annotations

import re

from ..cursors import decode_export_cursor, export_cursor
from ..errors import BoardNotFound, InvalidQuery
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import BOARD_ID_PATTERN, Board
from ..models.requests import ImportedSubmission
from ..models.transfer import (
    ExportedBoard,
    ExportedEntry,
    ExportLine,
    ExportPage,
    ImportReceipt,
    StoredSubmissionLine,
)
from ..models.views import BoardView
from ..stores.base import RecordArchive
from ..views import board_view
from .boards import BoardKeeper, check_belongs, default_board_id, live
from .pushing import check_record_size, keep_in_archive, scored_write

EXPORT_ENTRIES = 500
EXPORT_SUBMISSIONS = 25  # with their records, up to 64 KiB each: a page stays under 2 MB


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

    def import_board(self, board: Board, caller: Caller = LOCAL_ORGANISER) -> tuple[BoardView, bool]:
        """Create the exported board unless a board with its id exists (then that board's own
        settings stay). Returns the board and whether it was created."""
        now = self.clock()
        expected = default_board_id(board.track, board.direction, board.race_type)
        kind = "default" if board.board_id == expected else "named"
        if kind == "named" and not re.match(BOARD_ID_PATTERN, board.board_id):
            raise InvalidQuery(f"{board.board_id!r} is not a board id: letters, digits, _ - .")
        board = board.model_copy(update={"kind": kind, "deleted_at": None})
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
        check_record_size(record)
        submission, entry = scored_write(record, board, item.submitted_at)
        audit = self.keeper.event(board_id, "import", caller, self.clock(), racer=record.racer,
                                  submission_id=record.submission_id)
        if self.store.get_submission(board_id, submission.racer_key, record.submission_id) is None:
            keep_in_archive(self.archive, board_id, record)
        outcome = self.store.record_submission(submission, record, entry, audit=audit)
        return ImportReceipt(status="duplicate" if outcome.duplicate else "created",
                             board_id=board_id, submission_id=record.submission_id)
