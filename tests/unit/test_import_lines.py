"""An export's submission lines are read with their records' designs shared (each design read
once): what that prepares is, line for line, what reading every line whole prepares, for lines
as drboard writes them and for lines of any other form (spaces, another key order, a number
written another way); and a bad line is named as reading it whole names it."""

from __future__ import annotations

import functools
import re
from datetime import UTC, datetime
from pathlib import Path

import pytest
from drboard_assembler import assemble
from drboard_assembler.record import Record
from drboard_cli import transfer
from drboard_functions.models.domain import Board
from drboard_functions.models.transfer import StoredSubmissionLine
from drboard_functions.service import scored_write
from drboard_functions.service.loading import PreparedSubmission, prepare_submission

from tests.recordkit import make_record

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
TRACK = "reInvent2019_track"
BOARD = Board(board_id=TRACK, track=TRACK, title="Smile Speedway", kind="default",
              created_at=datetime(2026, 3, 1, tzinfo=UTC))


def line_of(record: Record) -> bytes:
    """The record's submission line, as an export writes it."""
    submission, _ = scored_write(record, BOARD, datetime(2026, 3, 2, 12, tzinfo=UTC))
    return StoredSubmissionLine.of(submission, record.model_dump_json()).model_dump_json().encode() + b"\n"


def records() -> list[Record]:
    found = [assemble(folder) for folder in sorted(EXAMPLES.iterdir()) if folder.is_dir()]
    shared = [make_record(name, [(9000 + n, 100), (9400, 100)]) for n, name in enumerate("ABC")]
    on_board = [record for record in found if record.track == TRACK and record.direction != "cw"
                and record.race_type == BOARD.race_type]
    return on_board + shared


def reworded(line: bytes) -> list[bytes]:
    """The same line in other forms a reader takes alike (or nearly: 3 for 3.0)."""
    return [
        line.replace(b'":', b'": '),  # spaces
        line.replace(b'"design":', b'"design" :'),
        re.sub(rb'"speed":(\d+)\.0\b', rb'"speed":\1', line),  # a whole number without its .0
        line.replace(b'"max_speed":', b'"max_speed":1.0,"max_speed":', 1),  # a key twice
        re.sub(rb',"training":(null|\{.*?\}),"provenance"', rb',"provenance"', line),  # a default left out
    ]


def prepared(lines: list[bytes], shared: bool, monkeypatch: pytest.MonkeyPatch) -> list[PreparedSubmission]:
    with monkeypatch.context() as patch:
        if not shared:
            patch.setattr(transfer._SHARED_DESIGNS, "prepared", lambda *_: None)
        check = functools.partial(prepare_submission, BOARD)
        return transfer._prepared_chunk("export.jsonl", BOARD, check, list(enumerate(lines, 2))).prepared


def test_lines_read_with_shared_designs_prepare_what_lines_read_whole_prepare(
        monkeypatch: pytest.MonkeyPatch) -> None:
    lines = [line_of(record) for record in records()]
    others = [other for line in lines[-2:] for other in reworded(line)]
    whole = prepared(lines + others, shared=False, monkeypatch=monkeypatch)
    read = transfer._SHARED_DESIGNS.prepared
    taken: list[bool] = []
    monkeypatch.setattr(transfer._SHARED_DESIGNS, "prepared",
                        lambda *args: taken.append(read(*args) is not None) or read(*args))
    assert prepared(lines + others, shared=True, monkeypatch=monkeypatch) == whole
    assert taken == [True] * len(lines) + [False] * len(others)
    assert prepared(lines, shared=True, monkeypatch=monkeypatch) == whole[:len(lines)], (
        "designs met before")


@pytest.mark.parametrize(("good", "bad", "says"), [
    (b'"speed":', b'"speed":-', r"record\.design\.action_space\.actions\[0\]\.speed: "),
    (b'"design":{', b'"design":{"colour":"red",', r"record\.design\.colour: "),
    (b'"model_name":"', b'"model_name":"tampered-', r"record\.submission_id: does not match"),
], ids=["a design out of bounds", "a design with a field too many", "tampered"])
def test_a_bad_line_is_named_as_reading_it_whole_names_it(
        monkeypatch: pytest.MonkeyPatch, good: bytes, bad: bytes, says: str) -> None:
    good_line = line_of(make_record("A", [(9000, 100)]))
    head, record = good_line.split(b'"record":', 1)
    lines = [good_line, head + b'"record":' + record.replace(good, bad, 1)]
    for shared in (True, False):
        with pytest.raises(transfer.BadExportFile, match=rf"^export\.jsonl:3: {says}"):
            prepared(lines, shared=shared, monkeypatch=monkeypatch)
