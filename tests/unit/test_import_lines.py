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
from drboard_assembler.record import Record, content_hash
from drboard_cli import transfer
from drboard_functions.models.domain import Board
from drboard_functions.models.transfer import StoredSubmissionLine
from drboard_functions.service import scored_write
from drboard_functions.service.loading import PreparedSubmission, prepare_submission
from drboard_functions.stores.base import stored_record

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
    return transfer._prepared_chunk("export.jsonl", BOARD, check, transfer._lines(
        "export.jsonl", 1, b"\n".join(line.removesuffix(b"\n") for line in lines))).prepared


def without_record_json(found: PreparedSubmission) -> PreparedSubmission:
    return found._replace(row=found.row._replace(record=""))


def test_lines_in_other_forms_prepare_what_drboard_s_own_lines_prepare() -> None:
    """The same record in another form is the same submission; the board keeps the record's
    JSON as the line held it (drboard's own lines: as the record writes itself out), which
    reads back as the same record."""
    lines = [line_of(record) for record in records()]
    own = prepared(lines)
    assert [p.row.submission_id for p in own] == [record.submission_id for record in records()]
    assert [p.row.record for p in own] == [record.model_dump_json() for record in records()]
    for line, expected in zip(lines[-2:], own[-2:], strict=True):
        others = reworded(line)
        assert all(other != line for other in others)
        found = prepared(others)
        assert [without_record_json(p) for p in found] == [without_record_json(expected)] * len(others)
        stored = stored_record(expected.row.record)
        assert [stored_record(p.row.record) for p in found] == [stored] * len(found)


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


def test_a_record_holding_a_record_member_of_its_own_imports_as_any_other() -> None:
    """A line is read in its two parts only where its split is its own: a record whose design
    holds a "record" member is read whole, and imports as any other."""
    plain = make_record("Ada", [(9000, 100)])
    dumped = plain.model_dump(mode="json")
    dumped["design"]["hyperparameters"]["other"] = {"note": 1, "record": "kept"}
    draft = Record.model_validate(dumped, context={"draft": True})
    record = draft.model_copy(update={"submission_id": content_hash(draft)})
    line = line_of(record)
    assert line.count(b',"record":') == 2
    [found] = prepared([line])
    assert (found.row.submission_id, found.row.record) == (record.submission_id, record.model_dump_json())
    assert stored_record(found.row.record) == record


@pytest.mark.parametrize("extra", [b',"note":1,"record":', b',"record":{},"record":'],
                         ids=["a member too many", "the record twice"])
def test_a_line_with_more_than_its_members_is_read_whole(extra: bytes) -> None:
    line = line_of(make_record("Ada", [(9000, 100)]))
    changed = line.replace(b',"record":', extra, 1)
    if extra.startswith(b',"note"'):
        with pytest.raises(transfer.BadExportFile, match=r"^export\.jsonl:2: note: "):
            prepared([changed])
    else:  # a key twice: the last one holds, as for any JSON reader
        assert [without_record_json(p) for p in prepared([changed])] == [
            without_record_json(p) for p in prepared([line])]
