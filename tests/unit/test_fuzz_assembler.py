"""Fuzzing on a small budget: every mutation of an example run assembles into a record or ends
in one clean error (exit 2, one line naming where). bench/fuzz_assembler.py runs thousands."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from click.testing import CliRunner
from drboard_assembler import AssemblyError, Record, assemble
from drboard_cli.main import cli

from tests.fuzzkit import mutate

BUDGET = int(os.environ.get("DRBOARD_FUZZ_CASES", "120"))


@pytest.mark.parametrize("seed", range(BUDGET))
def test_a_mutated_run_is_a_record_or_one_clean_error(seed: int, tmp_path: Path) -> None:
    path = mutate(seed, tmp_path / "case")
    try:
        record = assemble(path)
    except AssemblyError as error:
        message = str(error)
        assert message and "\n" not in message.strip()
        assert "Traceback" not in message
    else:
        assert isinstance(record, Record)
        assert Record.model_validate_json(record.model_dump_json()) == record


@pytest.mark.parametrize("seed", range(0, BUDGET, 6))
def test_the_cli_exits_0_or_2_on_a_mutated_run(seed: int, tmp_path: Path) -> None:
    path = mutate(seed, tmp_path / "case")
    result = CliRunner().invoke(cli, ["assemble", str(path)])
    assert result.exit_code in (0, 2), result.output
    assert result.exception is None or isinstance(result.exception, SystemExit)
    if result.exit_code == 2:
        assert result.output.startswith("error: ")
