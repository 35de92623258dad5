"""`drboard pull` on the embedded board answers a board that has not changed from the standings
kept beside it (no service, no model), with the same bytes as a pull through the service, and
never from standings the board has moved on from."""

from __future__ import annotations

import json
import os
import sqlite3
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import pytest
from click.testing import CliRunner
from drboard_cli import target
from drboard_cli.main import cli, out
from drboard_functions.stores.sqlite_standings import keep_page, kept_page

EXAMPLES = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())
PULL = ("pull", "--track", "reInvent2019")


def invoke(db: Path, *args: str, width: int = 80) -> str:
    out.cache_clear()  # a console as wide as this terminal
    result = CliRunner(env={"COLUMNS": str(width)}).invoke(cli, ["--db", str(db), *args],
                                                           catch_exceptions=False)
    assert result.exit_code == 0, result.stderr
    return result.stdout


def forget_kept(db: Path) -> None:
    """As when another program changed the board: no standings kept for it as it is."""
    with sqlite3.connect(db) as connection:
        connection.execute("DELETE FROM kept_standings")


@pytest.fixture
def board(tmp_path: Path) -> Path:
    """An embedded board holding every example run but Blaze's (the fastest), whose standings
    no pull has read yet."""
    db = tmp_path / "board.db"
    invoke(db, "push", *(str(p) for p in EXAMPLES if not p.name.startswith("blaze")))
    forget_kept(db)
    return db


@pytest.fixture
def service_pulls(monkeypatch: pytest.MonkeyPatch) -> list[Path]:
    """The board files a pull opened the service on (none: it answered from what is kept)."""
    opened: list[Path] = []
    open_board = target.local_board

    def counting(db: Path) -> target.BoardClient:
        opened.append(db)
        return open_board(db)

    monkeypatch.setattr(target, "local_board", counting)
    return opened


@pytest.mark.parametrize("args", [PULL, ("pull", "--board", "reInvent2019_track", "--top", "3")],
                         ids=" ".join)
@pytest.mark.parametrize("width", [60, 100, 160])
def test_a_repeated_pull_prints_what_the_service_printed_without_it(
        board: Path, service_pulls: list[Path], args: tuple[str, ...], width: int) -> None:
    through_service = invoke(board, *args, width=width)
    assert service_pulls == [board]
    kept = invoke(board, *args, width=width)
    assert service_pulls == [board], "the second pull opened the service"
    assert kept == through_service
    assert "Indy" in kept and "SAC" in kept
    assert ("52 % done" in kept) == ("--top" not in args)
    # a wide terminal shows each entry's model, conditions and submission time
    assert ("Submitted" in kept and "collision 5 s" in kept) == (width >= 110)


def test_a_board_requiring_conditions_reads_the_same_from_its_kept_standings(
        tmp_path: Path, service_pulls: list[Path]) -> None:
    db = tmp_path / "board.db"
    invoke(db, "board", "create", "pinned", "--track", "reInvent2019", "--title", "Pinned",
           "--require", "off-track-penalty=3", "--require", "trials=3")
    pinned = [str(p) for p in EXAMPLES if p.name.startswith(("comet", "drifter"))]  # 3 s, 3 trials
    invoke(db, "push", "--board", "pinned", *pinned)
    forget_kept(db)
    for width in (80, 160):
        through_service = invoke(db, "pull", "--board", "pinned", width=width)
        opened = len(service_pulls)
        assert invoke(db, "pull", "--board", "pinned", width=width) == through_service
        assert len(service_pulls) == opened, "the second pull opened the service"
        assert "evaluated with off-track penalty 3 s · trials 3" in " ".join(through_service.split())


@pytest.mark.parametrize("batch", [False, True], ids=["one run", "a batch"])
def test_after_a_push_the_pull_shows_the_new_leader_as_the_service_does(
        board: Path, service_pulls: list[Path], batch: bool) -> None:
    """`drboard push` keeps the standings it changed: the pull that follows answers from them."""
    before = invoke(board, *PULL)
    blaze = next(p for p in EXAMPLES if p.name.startswith("blaze"))
    invoke(board, "push", str(blaze), *([str(EXAMPLES[-1])] if batch else []))
    opened = len(service_pulls)
    after = invoke(board, *PULL)
    assert len(service_pulls) == opened, "the pull after the push opened the service"
    assert "Blaze" not in before
    assert after.index("Blaze") < after.index("Indy")
    forget_kept(board)
    assert invoke(board, *PULL) == after
    assert len(service_pulls) == opened + 1


def test_a_board_that_changed_another_way_is_read_again(board: Path, service_pulls: list[Path]) -> None:
    invoke(board, *PULL)
    invoke(board, "board", "remove-entry", "reInvent2019_track", "Indy")
    opened = len(service_pulls)
    removed = invoke(board, *PULL)
    assert len(service_pulls) == opened + 1
    assert "Indy" not in removed


def test_another_format_or_a_file_goes_through_the_service(
        board: Path, service_pulls: list[Path], tmp_path: Path) -> None:
    invoke(board, *PULL)
    as_json = json.loads(invoke(board, *PULL, "--format", "json"))
    invoke(board, *PULL, "-o", str(tmp_path / "standings.txt"))
    assert len(service_pulls) == 3
    assert as_json["entries"][0]["racer"] == "Indy"


def test_a_board_file_without_kept_standings_is_read_through_the_service(
        board: Path, service_pulls: list[Path]) -> None:
    """A board file from before kept standings (or whose copies were dropped) answers as ever."""
    expected = invoke(board, *PULL)
    with sqlite3.connect(board) as db:
        db.execute("DROP TABLE kept_standings")
    assert invoke(board, *PULL) == expected
    assert invoke(board, *PULL) == expected
    assert len(service_pulls) == 2


def test_a_kept_page_holds_until_the_board_next_opens_or_closes(board: Path) -> None:
    invoke(board, *PULL)
    with sqlite3.connect(board) as db:
        version, = db.execute("SELECT version FROM boards WHERE board_id = 'reInvent2019_track'").fetchone()
    assert keep_page(board, "reInvent2019_track", 25, version, fresh_until=1000.0, page='{"k": 1}')
    assert kept_page(board, "reInvent2019_track", 25, now=999.0) == '{"k": 1}'
    assert kept_page(board, "reInvent2019_track", 25, now=1000.0) is None
    assert kept_page(board, "reInvent2019_track", 10, now=999.0) is None  # another page size
    assert not keep_page(board, "reInvent2019_track", 25, version - 1, None, "{}"), "an older read"


def test_private_designs_read_the_same_and_are_kept_only_until_the_board_closes(
        tmp_path: Path, service_pulls: list[Path]) -> None:
    db = tmp_path / "board.db"
    invoke(db, "board", "create", "night", "--track", "reInvent2019", "--title", "Night race",
           "--designs", "after-close", "--closes-at", "2099-01-01T20:00:00Z")
    invoke(db, "push", "--board", "night", *(str(p) for p in EXAMPLES[:3]))
    opened = len(service_pulls)
    kept = invoke(db, "pull", "--board", "night")
    forget_kept(db)
    through_service = invoke(db, "pull", "--board", "night")
    assert kept == through_service
    assert len(service_pulls) == opened + 1
    assert through_service.count("private until the board closes") == 3
    with sqlite3.connect(db) as connection:
        fresh_until, = connection.execute("SELECT fresh_until FROM kept_standings").fetchone()
    assert fresh_until == datetime(2099, 1, 1, 20, tzinfo=UTC).timestamp()


def test_a_board_row_other_than_the_one_read_is_not_answered_from_its_copy(tmp_path: Path) -> None:
    """A board deleted and created again under the same id starts its versions over: the copy
    holds for the very board row it was read from, not for its version alone."""
    db = tmp_path / "board.db"
    invoke(db, "board", "create", "night", "--track", "reInvent2019", "--title", "Night race")
    invoke(db, "push", "--board", "night", str(EXAMPLES[0]))
    invoke(db, "pull", "--board", "night")
    with sqlite3.connect(db) as connection:  # another board row, at the same version
        connection.execute("UPDATE boards SET board = replace(board, 'Night race', 'Day race') "
                           "WHERE board_id = 'night'")
    assert kept_page(db, "night", 25, now=0.0) is None
    assert "Day race" in invoke(db, "pull", "--board", "night")


def test_a_kept_pull_run_as_the_program_loads_no_model(board: Path) -> None:
    invoke(board, *PULL)
    probe = ("import atexit, json, sys\n"
             "atexit.register(lambda: print(json.dumps(sorted(sys.modules)), file=sys.stderr))\n"
             "from drboard_cli.main import cli\n"
             f"cli(['--db', {str(board)!r}, *{list(PULL)!r}], prog_name='drboard')\n")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=False,
                          env={**os.environ, "COLUMNS": "80"})
    assert done.returncode == 0, done.stderr
    assert done.stdout == invoke(board, *PULL)
    loaded = json.loads(done.stderr.splitlines()[-1])
    assert [m for m in loaded if m.startswith(("pydantic", "drboard_functions.service",
                                               "drboard_functions.models", "drboard_cli.render"))] == []
