"""`drboard season ...` on the embedded board: create, rounds, the final, standings in every
format, show, list, close and reopen, and the messages and exit codes of bad input."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest
from drboard_functions.models.requests import BoardSpec
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record
from tests.unit.test_cli_boards import EXAMPLES, Clock, Drboard, clock, drboard

__all__ = ["clock", "drboard"]

SEASON = "club-2026"


@pytest.fixture
def nights(drboard: Drboard, clock: Clock) -> Drboard:
    """Two race nights: Ada, Bo, Cy in January; Bo, Ada, Cy, Di in February; and a final."""
    store = SqliteStore(drboard.db)
    service = LeaderboardService(store, clock=clock)
    for board_id in ("jan", "feb", "final"):
        service.create_board(BoardSpec(board_id=board_id, title=f"{board_id.title()} night",
                                       track="reInvent2019"))
    for board_id, order in (("jan", ["Ada", "Bo", "Cy"]), ("feb", ["Bo", "Ada", "Cy", "Di"])):
        for n, racer in enumerate(order):
            clock.advance(minutes=1)
            service.push(make_record(racer, [(10_000 + 100 * n, 100)], model=board_id), board_id)
    store.close()
    drboard.ok("season", "create", SEASON, "--title", "Club season 2026", "--participation", "1")
    return drboard


def rows(text: str) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(text)))


def test_an_organiser_makes_a_season_and_reads_its_standings(nights: Drboard) -> None:
    nights.ok("season", "add-round", SEASON, "jan")
    shown = nights.ok("season", "add-round", SEASON, "feb", "--weight", "2")
    assert "R2 counts ×2" in shown and "jan" in shown and "Feb night" in shown
    table = nights.ok("season", "standings", SEASON)
    assert table.index("Bo") < table.index("Ada") < table.index("Cy") < table.index("Di")
    listed = rows(nights.ok("season", "standings", SEASON, "--format", "csv"))
    assert [(r["rank"], r["racer"], r["points"]) for r in listed] == [
        ("1", "Bo", "71"), ("2", "Ada", "64"), ("3", "Cy", "48"), ("4", "Di", "26")]
    assert listed[0]["r1_place"] == "2nd" and listed[0]["r2_points"] == "52"
    assert listed[3]["r1_place"] == "" and listed[3]["r1_counted"] == "False"
    data = nights.json("season", "standings", SEASON)
    assert data["season"]["rounds"][1]["weight"] == 2.0 and len(data["standings"]) == 4
    markdown = nights.ok("season", "standings", SEASON, "--format", "markdown")
    assert "| 1 | Bo | 71 | 2nd 19 | 1st 52 |" in markdown


def test_best_of_strikes_the_rounds_that_do_not_count(nights: Drboard) -> None:
    for board_id in ("jan", "feb"):
        nights.ok("season", "add-round", SEASON, board_id)
    nights.ok("season", "update", SEASON, "--best-of", "1")
    listed = rows(nights.ok("season", "standings", SEASON, "--format", "csv"))
    assert [(r["racer"], r["points"], r["r1_counted"], r["r2_counted"]) for r in listed[:2]] == [
        ("Ada", "26", "True", "False"), ("Bo", "26", "False", "True")]
    assert "~~2nd 19~~" in nights.ok("season", "standings", SEASON, "--format", "markdown")
    assert "struck: past the best 1, not counted" in " ".join(
        nights.ok("season", "standings", SEASON).split())
    nights.ok("season", "update", SEASON, "--best-of", "2")  # both rounds count for everyone
    assert "struck" not in nights.ok("season", "standings", SEASON)
    nights.ok("season", "update", SEASON, "--best-of", "none")
    assert rows(nights.ok("season", "standings", SEASON, "--format", "csv"))[0]["points"] == "45"


def test_points_tables_of_ones_own(nights: Drboard) -> None:
    nights.ok("season", "add-round", SEASON, "feb")
    nights.ok("season", "update", SEASON, "--points", "10, 6, 4", "--participation", "0")
    assert [r["points"] for r in rows(nights.ok("season", "standings", SEASON, "--format", "csv"))] == [
        "10", "6", "4", "0"]
    shown = nights.ok("season", "update", SEASON, "--percentile", "100")
    assert "Points by place in each round's field: 100 to the winner" in shown
    assert [r["points"] for r in rows(nights.ok("season", "standings", SEASON, "--format", "csv"))] == [
        "100", "75", "50", "25"]


def test_the_final_takes_only_the_qualifiers(nights: Drboard, tmp_path: Path) -> None:
    for board_id in ("jan", "feb"):
        nights.ok("season", "add-round", SEASON, board_id)
    shown = nights.ok("season", "final", SEASON, "final", "--top", "2")
    assert "final: the top 2 of the season (Ada, Bo)" in " ".join(shown.split())
    blaze = next(p for p in EXAMPLES if p.name.startswith("blaze"))
    refused = nights("push", str(blaze), "--board", "final")
    assert refused.exit_code == 1
    assert "did not qualify" in refused.stderr and "Ada, Bo" in refused.stderr
    assert "Q" in nights.ok("season", "standings", SEASON).split("Ada")[1].split("\n")[0]
    nights.ok("season", "clear-final", SEASON)
    assert nights("push", str(blaze), "--board", "final").exit_code == 0


def test_show_list_close_and_reopen(nights: Drboard) -> None:
    nights.ok("season", "add-round", SEASON, "jan", "--weight", "1.5", "--always-counts")
    shown = " ".join(nights.ok("season", "show", SEASON).split())
    assert "Points 25-18-15-12-10-8-6-4-2-1 for places 1 to 10, and 1 for taking part" in shown
    assert "R1 counts ×1.5 and always counts" in shown and "Ties on points" in shown
    assert nights.json("season", "show", SEASON)["rounds"][0]["board_id"] == "jan"
    assert "ended" in nights.ok("season", "close", SEASON)
    assert [(s["season_id"], s["status"]) for s in nights.json("season", "list")] == [(SEASON, "CLOSED")]
    assert "ended" in nights.ok("season", "list")
    refused = nights("season", "add-round", SEASON, "feb")
    assert refused.exit_code == 2 and "reopen" in refused.stderr
    assert "running" in nights.ok("season", "reopen", SEASON)
    removed = nights.ok("season", "remove-round", SEASON, "jan")
    assert "No rounds yet" in removed


@pytest.mark.parametrize(("args", "code", "said"), [
    (["season", "create", SEASON, "--title", "Again"], 2, "already a season"),
    (["season", "create", "bad id", "--title", "T"], 2, "'ID'"),
    (["season", "create", "x", "--title", "T", "--points", "25,x"], 2, "'--points'"),
    (["season", "create", "x", "--title", "T", "--points", "10,20"], 2, "may not rise"),
    (["season", "create", "x", "--title", "T", "--points", "5", "--percentile", "9"], 2, "not both"),
    (["season", "update", SEASON], 2, "at least one option"),
    (["season", "standings", "nowhere"], 1, "no season 'nowhere'"),
    (["season", "add-round", SEASON, "nowhere"], 1, "no board 'nowhere'"),
    (["season", "final", SEASON, "final", "--top", "2", "--from-round", "feb"], 2, "not a round"),
])
def test_bad_input_says_what_and_exits_non_zero(nights: Drboard, args: list[str], code: int,
                                                 said: str) -> None:
    result = nights(*args)
    assert result.exit_code == code, result.stderr
    assert said in result.stderr
