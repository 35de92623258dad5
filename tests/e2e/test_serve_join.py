"""Racers on the network join a `drboard serve` board with its join code, and push only as
themselves; the serving computer stays the organiser."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from drboard_cli import tokens
from drboard_cli.joins import JoinDesk
from drboard_cli.serve import BoardServer, http_event
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import copy_of, make_record

LAN = "192.168.1.20"


class Clock:
    def __init__(self) -> None:
        self.now = datetime(2026, 3, 1, 18, 0, tzinfo=UTC)

    def __call__(self) -> datetime:
        return self.now


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def server(tmp_path: Path, clock: Clock) -> Iterator[BoardServer]:
    store = SqliteStore(":memory:")
    desk = JoinDesk(tmp_path / "board.joined.sqlite", code_minutes=30, clock=clock)
    server = BoardServer(("127.0.0.1", 0), LeaderboardService(store), desk)
    yield server
    server.server_close()
    desk.close()
    store.close()


def call(server: BoardServer, method: str, path: str, body: Any = None, *, address: str = LAN,
         token: str | None = None) -> tuple[int, dict[str, Any]]:
    headers = {"Content-Type": "application/json"}
    if token:
        headers["Authorization"] = f"Bearer {token}"
    data = body.model_dump_json().encode() if hasattr(body, "model_dump_json") else (
        json.dumps(body).encode() if body is not None else b"")
    result = server.handle_event(http_event(method, path, headers, data, address))
    return int(result["statusCode"]), json.loads(result["body"] or "{}")


def join(server: BoardServer) -> str:
    assert server.desk is not None
    status, joined = call(server, "POST", "/join", {"code": server.desk.current_code().code.lower()})
    assert status == 201, joined
    return str(joined["token"])


def push(server: BoardServer, racer: str, token: str | None, ms: int = 9000) -> tuple[int, dict[str, Any]]:
    record = make_record(racer, [(ms, 100)])
    return call(server, "POST", "/boards/reInvent2019_track/submissions", record, token=token)


def test_an_unsigned_push_from_the_network_is_refused(server: BoardServer) -> None:
    status, answer = push(server, "Ada", None)
    assert (status, answer["error"]) == (401, "NotSignedIn")
    assert "drboard join CODE" in answer["message"]
    assert server.service.boards() == []


def test_a_joined_racer_pushes_as_themselves_only(server: BoardServer) -> None:
    ada, bob = join(server), join(server)
    assert push(server, "Ada", ada)[0] == 201
    status, answer = push(server, "Ada", bob, ms=8000)
    assert (status, answer["error"]) == (403, "AliasTaken")
    assert push(server, "Bob", bob, ms=9500)[0] == 201
    assert call(server, "GET", "/me", token=ada)[1]["alias"] == "Ada"
    standings = call(server, "GET", "/boards/reInvent2019_track")[1]["entries"]
    assert [(e["racer"], e["time_ms"]) for e in standings] == [("Ada", 9000), ("Bob", 9500)]


def test_a_copied_run_from_another_racer_is_409(server: BoardServer) -> None:
    ada, bob = join(server), join(server)
    original = make_record("Ada", [(9000, 100)])
    assert call(server, "POST", "/boards/reInvent2019_track/submissions", original, token=ada)[0] == 201
    status, answer = call(server, "POST", "/boards/reInvent2019_track/submissions",
                          copy_of(original, "Bob"), token=bob)
    assert (status, answer["error"]) == (409, "CopiedRun")


def test_a_wrong_or_expired_code_joins_no_one(server: BoardServer, clock: Clock) -> None:
    assert server.desk is not None
    code = server.desk.current_code().code
    assert call(server, "POST", "/join", {"code": "AAAA-AAAA"})[0] == 403
    clock.now += timedelta(minutes=31)
    status, answer = call(server, "POST", "/join", {"code": code})
    assert (status, answer["error"]) == (403, "NotAuthorized")
    assert server.desk.current_code().code != code, "a new code replaces the one that ran out"
    assert call(server, "POST", "/join", {"nope": 1})[0] == 400


def test_a_made_up_token_signs_no_one_in(server: BoardServer) -> None:
    join(server)
    assert push(server, "Ada", "not-a-token")[0] == 401


def test_the_desk_keeps_only_digests_and_racers_stay_joined_across_restarts(
        tmp_path: Path, clock: Clock) -> None:
    path = tmp_path / "joined.sqlite"
    desk = JoinDesk(path, clock=clock)
    joined = desk.join(desk.current_code().code)
    desk.close()
    assert joined.token.encode() not in path.read_bytes()
    again = JoinDesk(path, clock=clock)
    caller = again.caller(joined.token)
    again.close()
    assert caller is not None and caller.principal == joined.principal


def test_network_racers_cannot_moderate_or_read_the_audit_trail(server: BoardServer) -> None:
    ada = join(server)
    push(server, "Ada", ada)
    for method, path in (("DELETE", "/boards/reInvent2019_track/racers/Ada"),
                         ("PUT", "/boards/reInvent2019_track/bans/Ada"),
                         ("GET", "/boards/reInvent2019_track/audit")):
        assert call(server, method, path, token=ada)[0] == 403, path
    status, trail = call(server, "GET", "/boards/reInvent2019_track/audit", address="127.0.0.1")
    assert status == 200
    [event] = trail["events"]
    assert event["action"] == "push" and event["actor"].startswith("join:")


def test_drboard_join_saves_a_token_only_its_owner_can_read(server: BoardServer) -> None:
    import threading

    from click.testing import CliRunner
    from drboard_cli.main import cli

    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}"
        assert server.desk is not None
        result = CliRunner().invoke(cli, ["--endpoint", url, "join", server.desk.current_code().code])
        assert result.exit_code == 0, result.output
        saved = tokens.load(url)
        assert saved is not None and saved.kind == "join"
        assert oct(os.stat(tokens.tokens_path()).st_mode & 0o777) == "0o600"
        wrong = CliRunner().invoke(cli, ["--endpoint", url, "join", "WRONG-CODE"])
        assert wrong.exit_code == 1 and "wrong or has run out" in wrong.output
    finally:
        server.shutdown()
