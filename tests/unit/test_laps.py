"""Results to analyse: a board's laps as CSV (the route, the service's pages and `drboard export
--laps`), a racer's submissions over time as CSV, and a run's laps as the metrics JSON that
deepracer-utils reads."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator
from datetime import datetime
from pathlib import Path

import pytest
from click.testing import CliRunner
from drboard_cli.main import cli
from drboard_functions.laps import LAP_COLUMNS, cell
from drboard_functions.models.requests import BoardSpec
from drboard_functions.routes import build_app, pull_router
from drboard_functions.service import LeaderboardService
from drboard_functions.service import results as results_room
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record
from tests.unit.test_routes import Client, Clock

TRACK = "reInvent2019_track"


@pytest.fixture
def service() -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    yield LeaderboardService(store, clock=Clock())
    store.close()


@pytest.fixture
def client(service: LeaderboardService) -> Client:
    return Client(build_app(pull_router), service)


def rows_of(text: str) -> list[dict[str, str]]:
    return list(csv.DictReader(io.StringIO(text)))


def test_every_lap_of_every_submission_is_one_row_a_spreadsheet_takes_as_it_is(
        service: LeaderboardService, client: Client) -> None:
    service.push(make_record("Ada", [(12000, 100), (13000, 100)], model="ada-v1"))
    service.push(make_record("Ada", runs=[[(11500, 100)], [(9000, 40), (11000, 100)]], model="ada-v2"))
    service.push(make_record("Blaze", [(10000, 100), (7000, 55.5)], model="=HYPERLINK(\"x\")"))

    answer = client.get(f"/boards/{TRACK}/laps.csv")

    assert answer["statusCode"] == 200
    assert answer["headers"]["Content-Type"] == "text/csv; charset=utf-8"
    assert "attachment" in answer["headers"]["Content-Disposition"]
    text = answer["body"]
    assert text.splitlines()[0] == ",".join(LAP_COLUMNS), "one header row"
    rows = rows_of(text)
    assert len(rows) == 2 + 3 + 2, "one row per lap of every run of every submission"
    for row in rows:
        moment = datetime.fromisoformat(row["submitted_at"])
        assert moment.utcoffset() is not None and row["submitted_at"].endswith("Z")
        float(row["time_s"]), float(row["completion_pct"]), int(row["lap"]), int(row["run"])
        assert row["complete"] in ("true", "false") and row["counted"] in ("true", "false")
    ada_v2 = [r for r in rows if r["model_name"] == "ada-v2"]
    assert [(r["run"], r["lap"], r["time_s"], r["complete"]) for r in ada_v2] == [
        ("1", "1", "11.5", "true"), ("2", "1", "9", "false"), ("2", "2", "11", "true")]
    assert {r["counted"] for r in ada_v2} == {"true"}, "Ada's second submission is her best"
    assert {r["counted"] for r in rows if r["model_name"] == "ada-v1"} == {"false"}
    blaze = [r for r in rows if r["racer"] == "Blaze"]
    assert blaze[0]["model_name"] == "'=HYPERLINK(\"x\")", "a formula is written as text"
    assert blaze[1]["completion_pct"] == "55.5" and blaze[1]["status"] == "Off track"


def test_cells_are_plain_numbers_times_and_text() -> None:
    assert cell(None) == "" and cell(True) == "true" and cell(12) == "12"
    assert cell(9.5) == "9.5" and cell(100.0) == "100" and cell(-3.25) == "-3.25"
    for text in ("=1+2", "+cmd", "-2+3", "@SUM(A1)", "\tx"):
        assert cell(text) == "'" + text, "a text cell never starts a formula"
    assert cell("Ada") == "Ada"


def test_a_big_board_comes_a_page_at_a_time_and_the_pages_make_one_file(
        service: LeaderboardService, client: Client, monkeypatch: pytest.MonkeyPatch) -> None:
    for n in range(5):
        service.push(make_record(f"Racer{n}", [(10000 + n, 100)]))
    whole = rows_of(client.get(f"/boards/{TRACK}/laps.csv")["body"])
    monkeypatch.setattr(results_room, "LAPS_PAGE", 2)

    first = client.get(f"/boards/{TRACK}/laps.csv")
    link = first["headers"]["Link"]
    assert link.startswith(f"</boards/{TRACK}/laps.csv?cursor=") and link.endswith('>; rel="next"')
    cursor = link[link.index("cursor=") + 7:link.index(">")]
    second = client.get(f"/boards/{TRACK}/laps.csv", cursor=cursor)
    assert not second["body"].startswith("board_id,"), "a later page has no header row"

    pages, cursor_or_none = [], None
    while True:
        page = service.laps_page(TRACK, cursor_or_none)
        pages.extend(page.rows)
        cursor_or_none = page.next_cursor
        if cursor_or_none is None:
            break
    assert len(pages) == len(whole) == 5
    assert sorted(r["racer"] for r in pages) == sorted(r["racer"] for r in whole)


def test_a_board_that_keeps_designs_private_keeps_its_laps_until_it_closes(
        service: LeaderboardService, client: Client) -> None:
    service.create_board(BoardSpec(board_id="night", title="Night", track="reInvent2019",
                                   designs="after-close"))
    service.push(make_record("Ada"), "night")
    answer = client.get("/boards/night/laps.csv")
    assert answer["statusCode"] == 403 and json.loads(answer["body"])["error"] == "DesignsPrivate"
    service.close_board("night")
    assert client.get("/boards/night/laps.csv")["statusCode"] == 200


# ---- one run's laps for deepracer-utils -------------------------------------------------------

#: What deepracer-utils' ``TrainingMetrics`` (deepracer/logs/metrics.py, 1.5) reads of a metrics
#: file it is given (``fname=`` or ``url=``): ``data["metrics"]`` as a table whose columns it
#: uses by these names; ``max(trial)`` divides the episodes into iterations, so trials are 1..;
#: a lap is complete when ``episode_status`` is "Lap complete"; ``time`` is ms / 1000.
DEEPRACER_UTILS_READS = {"trial": int, "episode": int, "phase": str, "reward_score": (float, type(None)),
                         "completion_percentage": (int, float), "episode_status": str,
                         "elapsed_time_in_milliseconds": int, "start_time": (int, float, type(None))}


def test_a_runs_laps_have_the_shape_deepracer_utils_reads(service: LeaderboardService,
                                                          client: Client) -> None:
    service.push(make_record("Ada", runs=[[(12000, 100), (8000, 60), (11000, 100)], [(9000, 100)]]))
    answer = client.get(f"/boards/{TRACK}/racers/ada/laps.json")
    assert answer["statusCode"] == 200
    metrics = json.loads(answer["body"])["metrics"]

    assert [m["elapsed_time_in_milliseconds"] for m in metrics] == [9000], \
        "the racer's counted run by default: the one that scored"
    every = json.loads(client.get(f"/boards/{TRACK}/racers/ada/laps.json", run="1")["body"])["metrics"]
    assert len(every) == 3
    for lap in every:
        for name, kind in DEEPRACER_UTILS_READS.items():
            assert isinstance(lap[name], kind), (name, lap[name])
        assert lap["phase"] == "evaluation"
    assert [m["trial"] for m in every] == [1, 2, 3] and max(m["trial"] for m in every) >= 1
    assert [m["episode_status"] == "Lap complete" for m in every] == [True, False, True]
    assert [m["elapsed_time_in_milliseconds"] / 1000 for m in every] == [12.0, 8.0, 11.0]
    assert client.get(f"/boards/{TRACK}/racers/ada/laps.json", run="3")["statusCode"] == 400
    assert client.get(f"/boards/{TRACK}/racers/nobody/laps.json")["statusCode"] == 404


# ---- a racer's submissions over time ----------------------------------------------------------


def test_a_racers_submissions_over_time_as_csv(service: LeaderboardService, client: Client) -> None:
    service.push(make_record("Ada", [(12000, 100)], model="v1"))
    service.push(make_record("Ada", [(30000, 50)], model="v2"))
    service.push(make_record("Ada", [(11000, 100)], model="v3"))

    rows = rows_of(client.get("/racers/Ada/submissions.csv")["body"])

    assert [(r["model_name"], r["qualified"], r["time_s"], r["counted"]) for r in rows] == [
        ("v1", "true", "12", "false"), ("v2", "false", "", "false"), ("v3", "true", "11", "true")]
    times = [datetime.fromisoformat(r["submitted_at"]) for r in rows]
    assert times == sorted(times), "oldest first"


# ---- the CLI ----------------------------------------------------------------------------------


def test_drboard_export_laps_writes_the_csv_and_history_format_csv(tmp_path: Path) -> None:
    db = tmp_path / "board.db"
    store = SqliteStore(db)
    board = LeaderboardService(store)
    board.push(make_record("Ada", [(12000, 100), (13000, 100)]))
    store.close()
    runner = CliRunner()

    out = tmp_path / "laps.csv"
    result = runner.invoke(cli, ["--db", str(db), "export", TRACK, "--laps", "-o", str(out)])
    assert result.exit_code == 0, result.output
    rows = rows_of(out.read_text("utf-8"))
    assert [(r["racer"], r["lap"], r["time_s"]) for r in rows] == [("Ada", "1", "12"), ("Ada", "2", "13")]

    history = runner.invoke(cli, ["--db", str(db), "history", "--racer", "ada", "--format", "csv"])
    assert history.exit_code == 0, history.output
    assert [r["time_s"] for r in rows_of(history.output)] == ["12"]

    missing = runner.invoke(cli, ["--db", str(db), "export", "nope", "--laps"])
    assert missing.exit_code == 1 and "nope" in missing.output
