"""Records that could poison or fake the standings are refused, on both sides of the wire:
numbers that are not finite or out of range, impossible laps, board ids a push may not take."""

from __future__ import annotations

import json
import random
import shutil
from pathlib import Path
from typing import Any

import pytest
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver
from click.testing import CliRunner
from drboard_assembler.record import MIN_LAP_MS, Record
from drboard_cli.main import cli
from drboard_functions.errors import BoardExists
from drboard_functions.models.requests import BoardSpec
from drboard_functions.routes import admin_router, build_app, pull_router, push_router
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore
from pydantic import ValidationError

from tests.recordkit import make_record
from tests.unit.test_routes import Client

EXAMPLES = Path(__file__).parents[2] / "examples"
SUBMIT = "/boards/reInvent2019_track/submissions"
HOSTILE_NUMBERS = ["NaN", "Infinity", "-Infinity", "1e400", "-1e400", "1" + "0" * 5000]


@pytest.fixture
def client() -> Client:
    app: APIGatewayHttpResolver = build_app(push_router, pull_router, admin_router)
    return Client(app, LeaderboardService(SqliteStore(":memory:")))


def record_json(**changes: Any) -> dict[str, Any]:
    record = json.loads(make_record("Ada", [(9000, 100), (9500, 100)]).model_dump_json())
    record["design"]["hyperparameters"].update(beta_entropy=0.01, other={"seed": 7})
    record["training"] = {"track": "reInvent2019_track", "episodes": 100, "training_time_s": 3600.0,
                          "best_reward": 120.5, "mean_reward": 60.0, "best_completion_pct": 100.0,
                          "mean_completion_pct": 55.0, "completed_laps": 10,
                          "curve": [{"episode": 1, "reward": 1.5, "completion_pct": 10.0}]}
    return record | changes


#: Where a number sits in a record, as a path into its JSON.
NUMBER_PATHS = [
    ("evaluations", 0, "laps", 0, "completion_pct"),
    ("evaluations", 0, "laps", 0, "time_ms"),
    ("design", "hyperparameters", "beta_entropy"),
    ("design", "hyperparameters", "other", "seed"),
    ("design", "action_space", "actions", 0, "speed"),
    ("training", "best_reward"),
    ("training", "curve", 0, "reward"),
    ("training", "training_time_s"),
]


def with_number(record: dict[str, Any], path: tuple[Any, ...], literal: str) -> str:
    """The record as JSON text with the number at ``path`` written as ``literal``."""
    marker = "__HOSTILE__"
    target = record = json.loads(json.dumps(record))
    for step in path[:-1]:
        target = target[step]
    target[path[-1]] = marker
    return json.dumps(record).replace(f'"{marker}"', literal)


@pytest.mark.parametrize("literal", HOSTILE_NUMBERS)
@pytest.mark.parametrize("path", NUMBER_PATHS, ids=lambda p: ".".join(map(str, p)))
def test_the_push_route_refuses_numbers_that_are_not_finite_or_too_big(
        client: Client, path: tuple[Any, ...], literal: str) -> None:
    response = client.request("POST", SUBMIT, body=with_number(record_json(), path, literal))
    assert response["statusCode"] == 422, response["body"][:300]
    answer = json.loads(response["body"])
    assert answer["error"] == "InvalidSubmission"
    assert client.get("/boards")["statusCode"] == 200
    assert json.loads(client.get("/boards")["body"])["boards"] == [], "nothing was written"


def test_a_record_nested_too_deeply_is_refused_not_crashed_on(client: Client) -> None:
    body = '{"racer": ' + "[" * 30_000 + "]" * 30_000 + "}"
    response = client.request("POST", SUBMIT, body=body)
    assert response["statusCode"] in (413, 422)


def random_record(rng: random.Random) -> dict[str, Any]:
    """A record with a number at some place replaced by an extreme value (valid or not)."""
    extremes: list[Any] = [0, -1, 1e-300, 1e9, -1e9, 1e9 + 1, 2**53, 2**63, -(2**63), 99.999999,
                           100, 100.0000001, 10, 10.0001, 90, 90.5, MIN_LAP_MS, 86_400_000]
    record = record_json()
    target = record
    path = rng.choice(NUMBER_PATHS)
    for step in path[:-1]:
        target = target[step]
    target[path[-1]] = rng.choice(extremes)
    return record


def test_no_record_the_board_accepts_can_make_a_read_crash(client: Client) -> None:
    """Every record either fails validation with a clean error, or is stored and then read back
    whole by every read: the standings, the racer, the history, the export, the web page."""
    rng = random.Random(20261124)
    accepted = 0
    for attempt in range(200):
        candidate = random_record(rng)
        candidate["racer"] = f"Racer {attempt}"
        for lap in candidate["evaluations"][0]["laps"]:  # each racer's own run, not a copy
            lap["trial"] += 100 * attempt
        candidate["submission_id"] = "0" * 64
        try:
            record = Record.build(**Record.model_validate(candidate, context={"draft": True})
                                  .model_dump(exclude={"submission_id"}))
        except ValidationError:
            continue
        response = client.request("POST", SUBMIT, body=record.model_dump_json())
        assert response["statusCode"] in (201, 409, 422), response["body"][:300]
        accepted += response["statusCode"] == 201
    assert accepted > 20, "the draw should hold plenty of valid records"
    for path in ("/boards/reInvent2019_track", "/boards/reInvent2019_track/view",
                 "/racers/Racer%200/submissions", "/"):
        assert client.get(path, limit="500")["statusCode"] == 200, path
    page = json.loads(client.get("/boards/reInvent2019_track", limit="500")["body"])
    assert len(page["entries"]) == accepted
    for entry in page["entries"]:
        racer = entry["racer"].replace(" ", "%20")
        assert client.get(f"/boards/reInvent2019_track/racers/{racer}")["statusCode"] == 200
    cursor = None
    while True:
        exported = client.get("/boards/reInvent2019_track/export", **({"cursor": cursor} if cursor else {}))
        assert exported["statusCode"] == 200
        cursor = json.loads(exported["body"])["next_cursor"]
        if cursor is None:
            break


# ---- the assembler refuses them too, naming the file and the field ---------------------------


@pytest.mark.parametrize("literal", ["NaN", "Infinity", "-1e400"])
def test_a_hyperparameters_file_with_a_number_that_is_not_finite_is_bad_input(
        tmp_path: Path, literal: str) -> None:
    run = tmp_path / "run"
    shutil.copytree(EXAMPLES / "speedy-ppo-console", run)
    [hyperparameters] = run.rglob("hyperparameters.json")
    data = json.loads(hyperparameters.read_text())
    data["beta_entropy"] = "__HOSTILE__"
    hyperparameters.write_text(json.dumps(data).replace('"__HOSTILE__"', literal))
    db = tmp_path / "board.db"
    result = CliRunner().invoke(cli, ["--db", str(db), "push", str(run)])
    assert result.exit_code == 2, result.output
    assert "hyperparameters.json" in result.stderr and "beta_entropy" in result.stderr
    assert "Traceback" not in result.output
    listed = CliRunner().invoke(cli, ["--db", str(db), "boards", "--format", "json"])
    assert json.loads(listed.stdout) == []


# ---- laps faster than any car ----------------------------------------------------------------


def test_a_zero_ms_lap_on_a_custom_track_is_refused() -> None:
    with pytest.raises(ValidationError, match=f"no complete lap takes under {MIN_LAP_MS} ms"):
        make_record("Ada", [(0, 100)], track="garage_loop")
    assert make_record("Ada", [(MIN_LAP_MS, 100)], track="garage_loop").best_run.best_lap_ms == MIN_LAP_MS


def test_a_model_claiming_10_m_s_cannot_lap_smile_speedway_in_1_157_s() -> None:
    with pytest.raises(ValidationError, match="top speed of 4 m/s"):
        make_record("Ada", [(1157, 100)], max_speed=10.0)
    assert make_record("Ada", [(7500, 100)], max_speed=10.0).best_run.best_lap_ms == 7500


# ---- board ids a push may not take ----------------------------------------------------------


def test_a_custom_track_cannot_take_an_official_tracks_default_board() -> None:
    service = LeaderboardService(SqliteStore(":memory:"))
    receipt = service.push(make_record("Ada", track="reInvent2019_track_oa"))
    assert receipt.board_id == "custom.reInvent2019_track_oa"
    from drboard_assembler.record import RaceType

    real = service.push(make_record("Bob", race_type=RaceType.OBJECT_AVOIDANCE))
    assert real.board_id == "reInvent2019_track_oa"
    assert service.racer("reInvent2019_track_oa", "Bob").board.race_type == RaceType.OBJECT_AVOIDANCE


def test_a_push_cannot_take_a_named_boards_id_before_the_organiser_creates_it() -> None:
    service = LeaderboardService(SqliteStore(":memory:"))
    assert service.push(make_record("Mallory", track="winter-cup")).board_id == "custom.winter-cup"
    view = service.create_board(BoardSpec(board_id="winter-cup", title="Winter Cup",
                                          track="reInvent2019"))
    assert view.kind == "named"
    with pytest.raises(BoardExists):
        service.create_board(BoardSpec(board_id="custom.winter-cup", title="Mine", track="reInvent2019"))
