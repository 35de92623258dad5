"""An export's submission lines in any form a JSON reader takes alike (spaces, a number written
another way, a key twice, a default left out) prepare what the lines drboard writes prepare;
and a bad line is named by its file, its line and its field."""

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


def prepared(lines: list[bytes]) -> list[PreparedSubmission]:
    check = functools.partial(prepare_submission, BOARD)
    return transfer._prepared_chunk("export.jsonl", BOARD, check, list(enumerate(lines, 2))).prepared


def test_lines_in_other_forms_prepare_what_drboard_s_own_lines_prepare() -> None:
    lines = [line_of(record) for record in records()]
    own = prepared(lines)
    assert [p.row.submission_id for p in own] == [record.submission_id for record in records()]
    for line, expected in zip(lines[-2:], own[-2:], strict=True):
        others = reworded(line)
        assert all(other != line for other in others)
        assert prepared(others) == [expected] * len(others)


@pytest.mark.parametrize(("good", "bad", "says"), [
    (b'"speed":', b'"speed":-', r"record\.design\.action_space\.actions\[0\]\.speed: "),
    (b'"design":{', b'"design":{"colour":"red",', r"record\.design\.colour: "),
    (b'"model_name":"', b'"model_name":"tampered-', r"record\.submission_id: does not match"),
], ids=["a design out of bounds", "a design with a field too many", "tampered"])
def test_a_bad_line_is_named_by_its_file_line_and_field(good: bytes, bad: bytes, says: str) -> None:
    good_line = line_of(make_record("A", [(9000, 100)]))
    head, record = good_line.split(b'"record":', 1)
    lines = [good_line, head + b'"record":' + record.replace(good, bad, 1)]
    with pytest.raises(transfer.BadExportFile, match=rf"^export\.jsonl:3: {says}"):
        prepared(lines)
