"""A record's content hash is the sha256 of its canonical JSON as first defined, for every kind of
content (text a JSON escape holds, numbers JSON writes with an exponent, fields added to the
record later, set or empty): the submission ids of records stored long ago still hold; and the
JSON a board stores of a record is the record's own JSON."""

from __future__ import annotations

import hashlib
import json
import re
from pathlib import Path
from typing import Any

import pytest
from drboard_assembler import assemble
from drboard_assembler.record import (
    Conditions,
    Lap,
    Record,
    content_hash,
    json_content_hash,
)

from tests.recordkit import make_record

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
LATER = {"design": ("sources",), "run": ("named_by_params", "conditions"),
         "lap": ("started_ms", "ended_ms", "immobilized", "reversed")}


def formula(record: Record) -> str:
    """The content hash as first defined: every field but the id and the assembler version,
    later fields left out while empty, keys sorted, no spaces, text as it is."""
    content = record.model_dump(mode="json", exclude={"submission_id", "assembler_version"})
    drop_empty(content["design"], LATER["design"])
    for run in content["evaluations"]:
        drop_empty(run, LATER["run"])
        for lap in run["laps"]:
            drop_empty(lap, LATER["lap"])
    canonical = json.dumps(content, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(canonical.encode("utf-8")).hexdigest()


def drop_empty(fields: dict[str, Any], names: tuple[str, ...]) -> None:
    for name in names:
        if fields.get(name) is None:
            fields.pop(name, None)


def edited(record: Record, **changes: Any) -> Record:
    """The record with ``changes`` (dotted paths into its dump), read back as stored."""
    dumped = record.model_dump(mode="json")
    for path, value in changes.items():
        *parents, last = path.split("__")
        node = dumped
        for part in parents:
            node = node[int(part)] if isinstance(node, list) else node[part]
        node[last] = value
    return Record.model_validate(dumped, context={"stored": True})


def records() -> list[Record]:
    plain = make_record("Ada", [(9100, 100), (9300, 100), (9500, 99.5)])
    found = [assemble(folder) for folder in sorted(EXAMPLES.iterdir()) if folder.is_dir()]
    return [
        *found,
        plain,
        make_record("Bob", [(9100, 100)]),  # the same design as Ada's
        edited(plain, racer="Zoë ☃ 𝔘", model_name="naïve/model"),
        edited(plain, evaluations__0__source='quote " backslash \\ bell \x07 del \x7f \u2028'),
        edited(plain, design__hyperparameters__lr=1e-05, design__hyperparameters__beta_entropy=-1e-07),
        edited(plain, design__hyperparameters__term_cond_avg_score=1e9,
               design__hyperparameters__e_greedy_value=123456789.0001),
        edited(plain, design__hyperparameters__other={"b": 1, "a": 1.0, "c": True, "d": "x",
                                                      "e": 0.0001, "f": -0.0}),
        edited(plain, design__hyperparameters__other={"a": 1.0, "b": 1, "c": True, "d": "x",
                                                      "e": 0.0001, "f": -0.0}),
        edited(plain, design__hyperparameters__other={"b": True, "a": 1, "c": 1.0}),
        edited(plain, design__sources={"algorithm": "model/model_metadata.json"}),
        edited(plain, design={}),
        edited(plain, evaluations__0__conditions=Conditions(off_track_penalty_s=2.5, trials=3)
               .model_dump(mode="json"), evaluations__0__named_by_params=False),
        edited(plain, evaluations__0__laps=[
            Lap(trial=1, time_ms=9100, completion_pct=100.0, status="Lap complete", started_ms=1e13,
                ended_ms=1.0000000000091e13, immobilized=0, reversed=0).model_dump(mode="json")],
            evaluations__0__laps_completed=1, evaluations__0__best_lap_ms=9100,
            evaluations__0__average_lap_ms=9100, evaluations__0__total_time_ms=9100,
            evaluations__0__best_completion_pct=100.0),
        edited(plain, custom_track=True, track="my.track", direction="cw"),
    ]


@pytest.mark.parametrize("record", records(), ids=lambda record: f"{record.racer}/{record.model_name}")
def test_the_hash_of_a_record_is_that_of_the_formula(record: Record) -> None:
    assert content_hash(record) == formula(record)


@pytest.mark.parametrize("record", records(), ids=lambda record: f"{record.racer}/{record.model_name}")
def test_the_json_a_record_writes_of_itself_hashes_as_the_record(record: Record) -> None:
    """An import hashes a record's JSON as the board stores it, without building the record."""
    assert json_content_hash(record.model_dump_json()) == content_hash(record)


def test_json_that_writes_a_value_otherwise_may_hash_otherwise() -> None:
    """Whole numbers written without their ``.0`` are the same record, not the same text: the
    JSON's hash differs, and an import settles it with the record's own (test_import_lines)."""
    plain = make_record("Ada", [(9100, 100)])
    rewritten = re.sub(r'"speed":(\d+)\.0\b', r'"speed":\1', plain.model_dump_json())
    assert Record.model_validate_json(rewritten, context={"stored": True}) == plain
    assert json_content_hash(rewritten) != content_hash(plain)


def test_designs_that_differ_only_in_a_value_s_type_hash_apart() -> None:
    plain = make_record("Ada", [(9100, 100)])
    one = [edited(plain, design__hyperparameters__other={"x": value}) for value in (1, 1.0, True, "1")]
    assert len({content_hash(record) for record in one}) == 4
    assert [content_hash(record) for record in one] == [formula(record) for record in one]


def test_text_utf_8_cannot_hold_fails_the_hash_as_the_formula_does() -> None:
    """Validation refuses such text; a record put together without it still hashes as before."""
    plain = make_record("Ada", [(9100, 100)])
    half = "half \udc80 a character"
    for lone in (plain.model_copy(update={"model_name": half}),
                 plain.model_copy(update={"design": plain.design.model_copy(
                     update={"neural_network": half})})):
        with pytest.raises(UnicodeEncodeError):
            formula(lone)
        with pytest.raises(UnicodeEncodeError):
            content_hash(lone)
