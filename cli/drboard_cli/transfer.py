"""Export a board as JSON lines, and import such a file into any board, idempotently.

An export is one JSON object per line: the board (its id, track, rules, window and limits), then
its entries in rank order, then every submission with its full record. It is written page by page
as the board answers, never held whole.

An import first reads the whole file and checks every line; one bad line names the file, the line
and the field, and nothing is imported. Then it creates the board (unless a board with that id
exists: its own settings stay) and replays every submission with its first submission time. The
target recomputes the entries from the submissions under its own rules: the export's entry lines
are informative. A submission already on the board is a duplicate and changes nothing, so
importing the same file twice is harmless.
"""

from __future__ import annotations

import errno
import re
import shutil
import sys
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO

from drboard_assembler.errors import field_path
from drboard_assembler.record import RaceType
from drboard_functions.models.domain import BOARD_ID_PATTERN, Board, run_mismatches
from drboard_functions.models.requests import ImportedSubmission
from drboard_functions.models.transfer import ExportedBoard, ExportedEntry, ExportedSubmission, ExportLine
from drboard_functions.models.views import BoardView
from pydantic import TypeAdapter, ValidationError

from .target import BoardClient

MAX_LINE_BYTES = 1 << 20  # a record is at most 64 KiB; its JSON line stays well under this
STDIN = "-"

_LINE = TypeAdapter[ExportLine](ExportLine)


class BadExportFile(Exception):
    """A line of an export file is not what an export writes: ``FILE:LINE: field: message``."""


# ---- export ----------------------------------------------------------------------------------


@dataclass
class ExportCounts:
    entries: int = 0
    submissions: int = 0


def export_lines(client: BoardClient, board_id: str) -> Iterator[ExportLine]:
    """The board's export, line by line, fetching one page at a time."""
    cursor: str | None = None
    while True:
        page = client.export_page(board_id, cursor)
        yield from page.lines
        cursor = page.next_cursor
        if cursor is None:
            return


def write_export(client: BoardClient, board_id: str, out: IO[str]) -> ExportCounts:
    counts = ExportCounts()
    for line in export_lines(client, board_id):
        out.write(line.model_dump_json() + "\n")
        if isinstance(line, ExportedEntry):
            counts.entries += 1
        elif isinstance(line, ExportedSubmission):
            counts.submissions += 1
    return counts


def write_laps(client: BoardClient, board_id: str, out: IO[str]) -> int:
    """Every lap of the board's submissions as one CSV file, page after page; the rows written."""
    from drboard_functions.laps import LAP_COLUMNS, csv_text

    cursor: str | None = None
    seen: set[str] = set()
    rows = 0
    while True:
        page = client.laps_page(board_id, cursor)
        out.write(csv_text(LAP_COLUMNS, page.rows, header=cursor is None))
        rows += len(page.rows)
        cursor = page.next_cursor
        if cursor is None or cursor in seen:
            return rows
        seen.add(cursor)


@contextmanager
def replaced_on_success(path: Path) -> Iterator[IO[str]]:
    """Write beside ``path`` and move into place only when the whole export is written."""
    if not path.parent.is_dir():
        raise FileNotFoundError(errno.ENOENT, "no such folder", str(path.parent))
    partial = path.with_name(path.name + ".partial")
    try:
        with partial.open("w", encoding="utf-8") as handle:
            yield handle
        partial.replace(path)
    finally:
        partial.unlink(missing_ok=True)


# ---- import ----------------------------------------------------------------------------------


@dataclass
class ExportContents:
    """What a checked export file holds."""

    board: Board
    entries: int = 0
    submissions: int = 0


@dataclass
class ImportSummary:
    board: BoardView
    board_created: bool
    created: int = 0
    duplicates: int = 0
    entry_lines: int = 0


@contextmanager
def opened_export(source: str) -> Iterator[tuple[str, IO[bytes]]]:
    """The export file to read twice, and the name to report: stdin is spooled to a temporary
    file first, since it can only be read once."""
    if source != STDIN:
        with Path(source).open("rb") as handle:
            yield source, handle
        return
    with tempfile.SpooledTemporaryFile(max_size=16 << 20) as spool:
        shutil.copyfileobj(sys.stdin.buffer, spool)
        spool.seek(0)
        yield "<stdin>", spool


def check_export(name: str, handle: IO[bytes]) -> ExportContents:
    """Read every line and check it; raise BadExportFile at the first bad one."""
    contents: ExportContents | None = None
    for number, line in _parsed_lines(name, handle):
        where = f"{name}:{number}"
        if isinstance(line, ExportedBoard):
            if contents is not None:
                raise BadExportFile(f"{where}: kind: a second board line (an export holds one board)")
            contents = ExportContents(board=line.board)
            continue
        if contents is None:
            raise BadExportFile(f"{where}: kind: the first line must be the board (\"kind\": \"board\")")
        if isinstance(line, ExportedEntry):
            contents.entries += 1
        else:
            _check_submission(where, line, contents.board)
            contents.submissions += 1
    if contents is None:
        raise BadExportFile(f"{name}: the file is empty: an export starts with its board line")
    return contents


def import_export(client: BoardClient, name: str, handle: IO[bytes], contents: ExportContents,
                  board_id: str | None, advance: Callable[[], None] = lambda: None) -> ImportSummary:
    """Create the board and replay every submission of a checked export file."""
    board = contents.board
    if board_id and board_id != board.board_id:
        board = _renamed(board, board_id)
    view, created = client.import_board(board)
    _check_same_track(view, board)
    summary = ImportSummary(board=view, board_created=created, entry_lines=contents.entries)
    handle.seek(0)
    for _, line in _parsed_lines(name, handle):
        if not isinstance(line, ExportedSubmission):
            continue
        item = ImportedSubmission(submitted_at=line.submission.submitted_at, record=line.record)
        receipt = client.import_submission(view.board_id, item)
        if receipt.status == "created":
            summary.created += 1
        else:
            summary.duplicates += 1
        advance()
    summary.board = client.board_page(view.board_id, 1, None).board  # with the racers just ranked
    return summary


def _parsed_lines(name: str, handle: IO[bytes]) -> Iterator[tuple[int, ExportLine]]:
    number = 0
    while raw := handle.readline(MAX_LINE_BYTES + 1):
        number += 1
        where = f"{name}:{number}"
        if len(raw) > MAX_LINE_BYTES:
            raise BadExportFile(f"{where}: the line is over {MAX_LINE_BYTES >> 20} MiB")
        if not raw.strip():
            continue
        try:
            yield number, _LINE.validate_json(raw)
        except ValidationError as error:
            raise BadExportFile(f"{where}: {_problem(error)}") from None


def _problem(error: ValidationError) -> str:
    """``field: message`` of the first problem; the location's first part is the line's kind."""
    problem = error.errors()[0]
    kind = problem["type"]
    if kind == "json_invalid":
        return f"line: not JSON ({problem['msg'].removeprefix('Invalid JSON: ')})"
    if kind.startswith("union_tag"):
        return "kind: must be \"board\", \"entry\" or \"submission\""
    location = field_path(problem["loc"][1:]) or "line"
    return f"{location}: {problem['msg'].removeprefix('Value error, ')}"


def _check_submission(where: str, line: ExportedSubmission, board: Board) -> None:
    submission, record = line.submission, line.record
    if submission.board_id != board.board_id:
        raise BadExportFile(f"{where}: submission.board_id: {submission.board_id!r} is not the "
                            f"exported board {board.board_id!r}")
    if submission.submission_id != record.submission_id:
        raise BadExportFile(f"{where}: submission.submission_id: not the record's submission id")
    mismatch = _track_mismatch(record.track, record.direction, record.race_type, board)
    if mismatch:
        raise BadExportFile(f"{where}: record.{mismatch}")


def _track_mismatch(track: str, direction: str | None, race_type: RaceType,
                    board: Board | BoardView) -> str:
    problem = {
        "track": f"track: {track} is not the board's track {board.track}",
        "direction": "direction: not the board's direction",
        "race_type": f"race_type: {race_type.value} is not the board's {board.race_type.value}",
    }
    mismatches = run_mismatches(track, direction, race_type, board)
    return problem[mismatches[0]] if mismatches else ""


def _check_same_track(target: BoardView, exported: Board) -> None:
    """An existing board keeps its settings, but its runs must be on the exported board's track."""
    mismatch = _track_mismatch(exported.track, exported.direction, exported.race_type, target)
    if mismatch:
        raise BadExportFile(f"board {target.board_id!r} already exists for other runs "
                            f"({mismatch}): import under another id with --board NEW_ID")


def _renamed(board: Board, board_id: str) -> Board:
    if not re.match(BOARD_ID_PATTERN, board_id):
        raise BadExportFile(f"--board: {board_id!r} is not a board id: letters, digits, `_`, `-` "
                            "and `.`, up to 64")
    try:
        return Board.model_validate(board.model_dump() | {"board_id": board_id})
    except ValidationError as error:
        raise BadExportFile(f"--board: {error.errors()[0]['msg']}") from None
