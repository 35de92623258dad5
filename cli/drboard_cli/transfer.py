"""Export a board as JSON lines, and import such a file into any board, idempotently.

An export is one JSON object per line: the board (its id, track, rules, window and limits), then
its entries in rank order, then every submission with its full record. It is written as the
board gives it (straight from the store on the embedded board, a page at a time over HTTP), never
held whole.

An import checks every line of the file; one bad line names the file, the line and the field,
and nothing is imported. It creates the board (unless a board with that id exists: its own
settings stay) and replays every submission with its first submission time. The target
recomputes the entries from the submissions under its own rules: the export's entry lines are
informative. A submission already on the board is a duplicate and changes nothing, so importing
the same file twice is harmless. Into the embedded board, the check also prepares every
submission and the board writes them in bulk as they are checked, all in one transaction that
is committed only once the last line is checked (``load_export``); a board over HTTP takes them
one request each, once the whole file is checked (``check_export`` then ``import_export``).
"""

from __future__ import annotations

import errno
import functools
import gc
import io
import itertools
import multiprocessing
import os
import pickle
import re
import shutil
import sys
import tempfile
import threading
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any, NamedTuple, TypeGuard

from drboard_assembler.errors import field_path
from drboard_assembler.record import RaceType, Record
from drboard_functions.errors import DomainError
from drboard_functions.models.domain import BOARD_ID_PATTERN, Board, Submission, run_mismatches
from drboard_functions.models.requests import ImportedSubmission
from drboard_functions.models.transfer import ExportedBoard, ExportedEntry, ExportedSubmission, ExportLine
from drboard_functions.models.views import BoardView
from pydantic import TypeAdapter, ValidationError

from .target import BoardClient

if TYPE_CHECKING:
    from drboard_functions.service import LeaderboardService
    from drboard_functions.service.loading import BulkImport, PreparedSubmission

#: Prepares an exported submission (its record, its first time, and the record's JSON as the line
#: holds it, or None) for the board imported into (``loading.prepare_submission``).
Prepare = Callable[[Record, datetime, str | None], "PreparedSubmission"]
#: Archives a prepared submission's record as the board stores it, where the board archives
#: (``BulkImport.keep``).
Keep = Callable[["PreparedSubmission"], None]

#: Starts a phase of a long command, with its total (None: unknown): how to say it advanced.
Phase = Callable[[str, int | None], Callable[[int], None]]

MAX_LINE_BYTES = 1 << 20  # a record is at most 64 KiB; its JSON line stays well under this
#: Submissions an import in bulk replays and writes at a time.
IMPORT_BATCH = 10_000
#: Bytes of an export's lines checked and prepared at a time (about 260 submissions and their
#: entry lines, some 4 KiB a pair; a chunk holds whole lines, so more where a line would be cut).
CHUNK_BYTES = 1 << 20
#: Chunks of that size that make about a batch (IMPORT_BATCH).
CHUNKS_A_BATCH = 40
#: From this size on (about 4,000 submissions, a second of checking), an export's lines are
#: checked on every core, in worker processes: checking a line (its record's schema, its
#: content hash, its score) is most of an import; starting the workers takes up to half a second.
PARALLEL_FROM_BYTES = 16 << 20
#: How much lower than the import's own process its checking workers run (``os.nice``): the
#: process writing the board, whose work cannot be split, goes first, and so does whatever else
#: the computer runs (a `drboard serve` answering racers); the workers take the CPU left.
WORKER_NICENESS = 10
#: How an import in bulk reads an export's records: as the board's own stored records are read
#: (schema and bounds; not today's rules of aliases, text, tracks and lap floors).
IMPORT_CHECKS = {"stored": True}
STDIN = "-"
WRITE_BUFFER_BYTES = 1 << 20

_LINE = TypeAdapter[ExportLine](ExportLine)
_SUBMISSION = TypeAdapter[Submission](Submission)
_RECORD = TypeAdapter[Record](Record)
#: A submission line as an export writes it: ``{"kind":"submission","submission":{…},"record":{…}}``.
_SUBMISSION_LINE = b'{"kind":"submission","submission":'
_RECORD_MEMBER = b',"record":'


class BadExportFile(Exception):
    """A line of an export file is not what an export writes: ``FILE:LINE: field: message``."""


# ---- export ----------------------------------------------------------------------------------


@dataclass
class ExportCounts:
    entries: int = 0
    submissions: int = 0


def write_export(client: BoardClient, board_id: str, out: IO[bytes]) -> ExportCounts:
    """Write the board's export, line by line as the board gives them."""
    counts = ExportCounts()
    for kind, line in client.export_lines(board_id):
        out.write(line)
        if kind == "entry":
            counts.entries += 1
        elif kind == "submission":
            counts.submissions += 1
    return counts


def write_laps(client: BoardClient, board_id: str, out: IO[bytes]) -> int:
    """Every lap of the board's submissions as one CSV file, page after page; the rows written."""
    from drboard_functions.laps import LAP_COLUMNS, csv_text

    cursor: str | None = None
    seen: set[str] = set()
    rows = 0
    while True:
        page = client.laps_page(board_id, cursor)
        out.write(csv_text(LAP_COLUMNS, page.rows, header=cursor is None).encode())
        rows += len(page.rows)
        cursor = page.next_cursor
        if cursor is None or cursor in seen:
            return rows
        seen.add(cursor)


def standard_output() -> IO[bytes]:
    """Standard output for bytes (whatever was printed to it as text goes out first)."""
    sys.stdout.flush()
    return sys.stdout.buffer


@contextmanager
def replaced_on_success(path: Path) -> Iterator[IO[bytes]]:
    """Write beside ``path`` and move into place only when the whole export is written."""
    if not path.parent.is_dir():
        raise FileNotFoundError(errno.ENOENT, "no such folder", str(path.parent))
    partial = path.with_name(path.name + ".partial")
    try:
        with partial.open("wb", buffering=WRITE_BUFFER_BYTES) as handle:
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
            _check_submission(where, line.submission, line.record, contents.board)
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


# ---- import in bulk (the embedded board) -------------------------------------------------------


def loads_in_bulk(client: BoardClient) -> TypeGuard[LeaderboardService]:
    """Whether the board runs in this process, where an import is written in bulk as its lines
    are checked (``load_export``); a board over HTTP takes the submissions one request each."""
    from drboard_functions.service import LeaderboardService

    return isinstance(client, LeaderboardService)


def load_export(service: LeaderboardService, name: str, handle: IO[bytes], board_id: str | None,
                phase: Phase = lambda _, __: lambda _: None) -> ImportSummary:
    """Import an export file in bulk, in one transaction: the board is created (unless it
    exists: its own settings stay) and the submissions written IMPORT_BATCH at a time as their
    lines are checked, and all of it is committed only once every line is checked and every
    submission written; one bad line names the file, the line and the field, and the
    transaction is rolled back: nothing is imported. Each record is checked for its schema and
    bounds, its size and its integrity (its submission id is its content's hash), as the
    board's stored records are: not against today's rules of aliases, text, tracks and lap
    floors (`drboard board recheck` flags the records those would refuse). A store that cannot
    hold an import in one transaction has every line checked (and every submission prepared,
    kept in a temporary file) before anything is written, then a transaction per batch."""
    size = _size(handle)
    bulk, exported, after = _opened(service, name, handle, board_id)
    with _cycles_collected_after(), _checking(name, exported, bulk, handle, after, size) as checked:
        counted = _counted(checked, phase("Checking the export", size))
        if bulk.holds_whole:
            with bulk.whole():
                summary = _loaded(bulk, counted, phase)
        else:
            with tempfile.TemporaryFile() as spool:
                summary = _loaded(bulk, _checked_first(counted, spool), phase)
    summary.board = service.board_page(summary.board.board_id, 1, None).board
    return summary


@contextmanager
def _cycles_collected_after() -> Iterator[None]:
    """Python's collector of reference cycles paused for the block (and in the workers it
    starts): an import makes no cycles, and would have it walk every row of the batch in hand
    again and again. What the block leaves alive is then handed to the collector's oldest
    generation: its first young pass would otherwise walk all of it (a quarter of a second
    after an import of 100,000 racers)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.freeze()
            gc.unfreeze()
            gc.enable()


def _worker_started() -> None:
    """A checking worker's start: behind the import's own process (WORKER_NICENESS), and without
    the cycle collector (its chunks make no cycles)."""
    if hasattr(os, "nice"):  # (not on Windows)
        with suppress(OSError):  # a system that refuses it gets a worker at its own priority
            os.nice(WORKER_NICENESS)
    gc.disable()


class _Chunk(NamedTuple):
    """Whole lines of an export: the number of the line before its first, where they start in
    the file, how many bytes they are, and those bytes (none where a worker reads them)."""

    after: int
    offset: int
    size: int
    data: bytes


class _Checked(NamedTuple):
    """A chunk of an export's lines checked: its prepared submissions, its entry lines, the
    bytes read, and where in the chunk lie the records its submissions store as the lines hold
    them: (which submission, first byte, end)."""

    prepared: list[PreparedSubmission]
    entries: int
    read: int
    records: list[tuple[int, int, int]]

    def without_records(self) -> _Checked:
        """The same, with the records that lie in the chunk left out (written ""): what a worker
        sends back, as the process it sends to has the chunk's bytes (``with_records``)."""
        prepared = self.prepared
        for index, _, _ in self.records:
            row = prepared[index].row
            prepared[index] = prepared[index]._replace(row=row._replace(record=""))
        return self

    def with_records(self, data: bytes) -> _Checked:
        """The records ``without_records`` left out, read again from the chunk's bytes."""
        prepared = self.prepared
        for index, start, end in self.records:
            row = prepared[index].row
            prepared[index] = prepared[index]._replace(row=row._replace(
                record=data[start:end].decode()))
        return self


def _opened(service: LeaderboardService, name: str, handle: IO[bytes],
            board_id: str | None) -> tuple[BulkImport, Board, int]:
    """The import of the export whose board line is read first: the import, the exported
    board, and that line's number."""
    first = _first_line(name, handle)
    if first is None:
        raise BadExportFile(f"{name}: the file is empty: an export starts with its board line")
    number, line = first
    if not isinstance(line, ExportedBoard):
        raise BadExportFile(f"{name}:{number}: kind: the first line must be the board "
                            "(\"kind\": \"board\")")
    exported = line.board
    board = _renamed(exported, board_id) if board_id and board_id != exported.board_id else exported
    bulk = service.bulk_import(board)
    _check_same_track(bulk.board, board)
    return bulk, exported, number


def _loaded(bulk: BulkImport, checked: Iterator[_Checked], phase: Phase) -> ImportSummary:
    """Open the board, then write the checked submissions IMPORT_BATCH at a time."""
    view, created = bulk.open()
    summary = ImportSummary(board=view, board_created=created)
    advance = phase("Importing submissions", None)
    batch: list[PreparedSubmission] = []
    for chunk in checked:
        summary.entry_lines += chunk.entries
        batch += chunk.prepared
        while len(batch) >= IMPORT_BATCH:
            _load(bulk, batch[:IMPORT_BATCH], summary, advance)
            batch = batch[IMPORT_BATCH:]
    if batch:
        _load(bulk, batch, summary, advance)
    return summary


def _load(bulk: BulkImport, batch: list[PreparedSubmission], summary: ImportSummary,
          advance: Callable[[int], None]) -> None:
    tally = bulk.load(batch)
    summary.created += tally.created
    summary.duplicates += tally.duplicates
    advance(len(batch))


def _counted(checked: Iterator[_Checked], advance: Callable[[int], None]) -> Iterator[_Checked]:
    for chunk in checked:
        advance(chunk.read)
        yield chunk


def _checked_first(checked: Iterator[_Checked], spool: IO[bytes]) -> Iterator[_Checked]:
    """Every chunk checked and kept in ``spool`` before the first is given back."""
    for chunk in checked:
        pickle.dump(chunk, spool, protocol=pickle.HIGHEST_PROTOCOL)
    spool.seek(0)
    return _unspooled(spool)


def _unspooled(spool: IO[bytes]) -> Iterator[_Checked]:
    while True:
        try:
            yield pickle.load(spool)
        except EOFError:
            return


@contextmanager
def _checking(name: str, exported: Board, bulk: BulkImport, handle: IO[bytes], after: int,
              size: int | None) -> Iterator[Iterator[_Checked]]:
    """Every chunk of the lines after line ``after`` checked and prepared (``_checked_chunk``),
    in the file's order. A big file's chunks are checked in worker processes, one per core,
    enough chunks ahead to keep them busy while a batch is written: the first bad line in the
    file is still the one named. Worker processes start (with the first chunks) when the block
    is entered, by fork where this process runs no other thread (a fork copies no other thread's
    locks), else by spawn. Forked workers read their chunks from the file themselves."""
    from drboard_functions.service.loading import prepare_submission

    prepare = functools.partial(prepare_submission, bulk.board)
    chunks = _chunks(name, handle, after)
    workers = _workers(size)
    if workers < 2 or bulk.archive is not None:  # an archive is written as each line is prepared
        yield (_checked_chunk(name, exported, prepare, chunk, bulk.keep) for chunk in chunks)
        return
    forks = threading.active_count() == 1 and os.name == "posix"
    check: Callable[[_Chunk], _Checked]
    if forks:
        check = functools.partial(_read_and_checked, handle.fileno(), name, exported, prepare)
        chunks = (chunk._replace(data=b"") for chunk in chunks)  # (read where they are checked)
    else:
        check = functools.partial(_checked_chunk, name, exported, prepare)
    pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context(
        "fork" if forks else "spawn"), initializer=_worker_started)
    file = handle.fileno() if forks else None
    try:
        ahead = _Ahead(pool, functools.partial(_sent_back, check), chunks, file)
        ahead.submit(CHUNKS_A_BATCH + 2 * workers)
        yield ahead.checked()
    finally:
        pool.shutdown(cancel_futures=True)


class _Ahead:
    """Chunks given to the worker processes ahead of the one written (a batch's, and two per
    worker, keep them busy while a batch is written), their results taken in the file's order,
    with their records read again from the chunk (``file``: where a chunk given without its bytes
    is read). A line that cannot be read (over the bound) is named once every line before it is
    checked: the first bad line in the file is the one named."""

    def __init__(self, pool: ProcessPoolExecutor, check: Callable[[_Chunk], _Checked],
                 chunks: Iterator[_Chunk], file: int | None) -> None:
        self.pool = pool
        self.check = check
        self.chunks = chunks
        self.file = file
        self.pending: deque[tuple[_Chunk, Future[_Checked]]] = deque()
        self.unread: BadExportFile | None = None

    def submit(self, count: int) -> None:
        if self.unread is not None:
            return
        try:
            for chunk in itertools.islice(self.chunks, count):
                self.pending.append((chunk, self.pool.submit(self.check, chunk)))
        except BadExportFile as error:
            self.unread = error

    def checked(self) -> Iterator[_Checked]:
        while self.pending:
            chunk, future = self.pending.popleft()
            done = future.result()
            self.submit(1)
            if done.records:
                data = chunk.data if self.file is None else os.pread(self.file, chunk.size,
                                                                     chunk.offset)
                done = done.with_records(data)
            yield done
        if self.unread is not None:
            raise self.unread


def _workers(size: int | None) -> int:
    """How many processes check a file of ``size`` bytes (unknown: one)."""
    if size is None or size < PARALLEL_FROM_BYTES:
        return 1
    cores = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else range(os.cpu_count() or 1)
    return len(cores)


def _first_line(name: str, handle: IO[bytes]) -> tuple[int, ExportLine] | None:
    for number, raw in _numbered(name, handle, 0):
        return number, _parsed(f"{name}:{number}", raw)
    return None


def _chunks(name: str, handle: IO[bytes], after: int) -> Iterator[_Chunk]:
    """The lines after line ``after`` (where ``handle`` is), CHUNK_BYTES or so at a time, in
    chunks of whole lines; only their ends are looked for here (lines are split, and each
    checked against the bound, where the chunk is checked: ``_checked_chunk``)."""
    offset = handle.tell()
    rest = b""
    while data := handle.read(CHUNK_BYTES):
        if rest:
            data = rest + data
        end = data.rfind(b"\n") + 1
        if not end:  # no line ends in it yet
            if len(data) > MAX_LINE_BYTES:
                raise _over_the_bound(name, after + 1)
            rest = data
            continue
        yield _Chunk(after, offset, end, data[:end])
        after += data.count(b"\n", 0, end)
        offset += end
        rest = data[end:]
    if rest:
        yield _Chunk(after, offset, len(rest), rest)


def _numbered(name: str, handle: IO[bytes], after: int) -> Iterator[tuple[int, bytes]]:
    """The file's lines that are not blank, numbered from ``after`` + 1, each within the bound."""
    number = after
    while raw := handle.readline(MAX_LINE_BYTES + 1):
        number += 1
        if len(raw) > MAX_LINE_BYTES:
            raise _over_the_bound(name, number)
        if not raw.isspace():  # (stripping would copy every line)
            yield number, raw


def _over_the_bound(name: str, number: int) -> BadExportFile:
    return BadExportFile(f"{name}:{number}: the line is over {MAX_LINE_BYTES >> 20} MiB")


def _sent_back(check: Callable[[_Chunk], _Checked], chunk: _Chunk) -> _Checked:
    """A chunk checked in a worker, as the worker sends it back: without the records that lie in
    the chunk, which the import's own process has (most of what a chunk's result would carry
    from one process to the other)."""
    return check(chunk).without_records()


def _read_and_checked(file: int, name: str, exported: Board, prepare: Prepare,
                      chunk: _Chunk) -> _Checked:
    """``_checked_chunk`` of a chunk given without its bytes, read here from the file (its
    descriptor, shared with a forked worker)."""
    data = os.pread(file, chunk.size, chunk.offset)
    return _checked_chunk(name, exported, prepare, chunk._replace(data=data))


def _checked_chunk(name: str, exported: Board, prepare: Prepare, chunk: _Chunk,
                   keep: Keep | None = None) -> _Checked:
    """Check a chunk of an export's lines after its board line and prepare its submissions."""
    return _prepared_chunk(name, exported, prepare, _lines(name, chunk.after, chunk.data), keep,
                           size=chunk.size)


def _lines(name: str, after: int, data: bytes) -> Iterator[tuple[int, int, bytes]]:
    """The lines of ``data`` that are not blank, numbered from ``after`` + 1, with where each
    starts in ``data``, each within the bound (BadExportFile when the line is reached, so that a
    bad line before it is named first)."""
    start = 0
    for number, raw in enumerate(data.split(b"\n"), after + 1):
        if len(raw) > MAX_LINE_BYTES:
            raise _over_the_bound(name, number)
        if raw and not raw.isspace():  # (stripping would copy every line)
            yield number, start, raw
        start += len(raw) + 1


def _prepared_chunk(name: str, exported: Board, prepare: Prepare,
                    lines: Iterable[tuple[int, int, bytes]], keep: Keep | None = None,
                    size: int = 0) -> _Checked:
    """Check numbered lines of an export after its board line (``size`` bytes of it), each with
    where it starts, and prepare their submissions."""
    prepared: list[PreparedSubmission] = []
    records: list[tuple[int, int, int]] = []
    entries = 0
    for number, start, raw in lines:
        where = f"{name}:{number}"
        read = _submission_line(raw)
        if read is None:
            line = _parsed(where, raw, IMPORT_CHECKS)
            if isinstance(line, ExportedBoard):
                raise BadExportFile(f"{where}: kind: a second board line (an export holds one board)")
            if isinstance(line, ExportedEntry):
                entries += 1
                continue
            record = line.record
            done = _prepared_line(where, line.submission, record, None, exported, prepare)
        else:
            submission, record, record_json, span = read
            done = _prepared_line(where, submission, record, record_json, exported, prepare)
            if done.row.record is record_json:  # stored as the line holds it
                records.append((len(prepared), start + span.start, start + span.stop))
        prepared.append(done)
        if keep is not None:
            keep(done)
    return _Checked(prepared, entries, size, records)


def _submission_line(raw: bytes) -> tuple[Submission, Record, str, slice] | None:
    """A submission line in the shape an export writes it, read as its two parts: its submission,
    and its record with the record's JSON as the line holds it (what the board stores; nothing is
    written out again) and where that JSON lies in the line. None for any other line, or one that
    does not read so (read whole then, which names its first problem)."""
    if not raw.startswith(_SUBMISSION_LINE):
        return None
    line = raw.rstrip()
    split = line.rfind(_RECORD_MEMBER)
    if split < 0 or not line.endswith(b"}"):
        return None
    # Both parts read as JSON values only where the split is the line's own: a "record" member
    # inside the record leaves the first part holding the record's start after its submission.
    span = slice(split + len(_RECORD_MEMBER), len(line) - 1)
    record_json = line[span]
    try:
        return (_SUBMISSION.validate_json(line[len(_SUBMISSION_LINE):split]),
                _RECORD.validate_json(record_json, context=IMPORT_CHECKS), record_json.decode(), span)
    except ValidationError:
        return None


def _prepared_line(where: str, submission: Submission, record: Record, record_json: str | None,
                   exported: Board, prepare: Prepare) -> PreparedSubmission:
    """Check a submission line for the exported board, and prepare it (BadExportFile)."""
    _check_submission(where, submission, record, exported)
    try:
        return prepare(record, submission.submitted_at, record_json)
    except DomainError as error:
        raise BadExportFile(f"{where}: {_refusal(error)}") from None


def _refusal(error: DomainError) -> str:
    """``field: message`` of a submission the board refuses to import."""
    if error.detail:
        return f"{error.detail[0]['loc']}: {error.detail[0]['msg']}"
    return f"record: {error.message}"


def _size(handle: IO[bytes]) -> int | None:
    try:
        return os.fstat(handle.fileno()).st_size
    except (OSError, io.UnsupportedOperation):
        return None


def _parsed_lines(name: str, handle: IO[bytes]) -> Iterator[tuple[int, ExportLine]]:
    for number, raw in _numbered(name, handle, 0):
        yield number, _parsed(f"{name}:{number}", raw)


def _parsed(where: str, raw: bytes, context: dict[str, Any] | None = None) -> ExportLine:
    try:
        return _LINE.validate_json(raw, context=context)
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


def _check_submission(where: str, submission: Submission, record: Record, board: Board) -> None:
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
    mismatches = run_mismatches(track, direction, race_type, board)
    if not mismatches:
        return ""
    return {
        "track": f"track: {track} is not the board's track {board.track}",
        "direction": "direction: not the board's direction",
        "race_type": f"race_type: {race_type.value} is not the board's {board.race_type.value}",
    }[mismatches[0]]


def _check_same_track(target: Board | BoardView, exported: Board) -> None:
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
