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
from drboard_cli.joins import ATTEMPTS_PER_WINDOW, JoinDesk, WrongCode
from drboard_cli.serve import BoardServer, http_event
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import copy_of, make_record

LAN = "192.168.1.20"
EXAMPLE = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())[0]


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
    desk = JoinDesk(tmp_path / "board.joined.sqlite", token_hours=12, clock=clock)
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


def test_a_wrong_code_joins_no_one_and_a_code_lasts_until_rotated(server: BoardServer,
                                                                  clock: Clock) -> None:
    assert server.desk is not None
    code = server.desk.current_code().code
    assert call(server, "POST", "/join", {"code": "AAAA-AAAA"})[0] == 403
    clock.now += timedelta(hours=20)
    assert server.desk.current_code().code == code, "the code is the night's"
    assert call(server, "POST", "/join", {"code": code})[0] == 201
    rotated = server.desk.rotate().code
    assert rotated != code
    status, answer = call(server, "POST", "/join", {"code": code})
    assert (status, answer["error"]) == (403, "NotAuthorized")
    assert call(server, "POST", "/join", {"code": rotated})[0] == 201
    assert call(server, "POST", "/join", {"nope": 1})[0] == 400


@pytest.mark.parametrize("code", ["ÄÄÄÄ-ÄÄÄÄ", "K7QM-3XWD\u202e", "日本語", "x" * 40])
def test_a_code_that_is_not_letters_and_digits_is_a_clean_400(server: BoardServer, code: str) -> None:
    status, answer = call(server, "POST", "/join", {"code": code})
    assert (status, answer["error"]) == (400, "InvalidQuery")


def test_the_code_survives_a_restart_of_serve(tmp_path: Path, clock: Clock) -> None:
    first = JoinDesk(tmp_path / "joined.sqlite", clock=clock)
    code = first.current_code().code
    first.close()
    again = JoinDesk(tmp_path / "joined.sqlite", clock=clock)
    try:
        assert again.current_code().code == code
        assert again.join(code.lower().replace("-", " ")).principal.startswith("join:")
    finally:
        again.close()


def test_a_code_joins_at_most_its_cap(tmp_path: Path, clock: Clock) -> None:
    desk = JoinDesk(tmp_path / "joined.sqlite", max_joins=2, clock=clock)
    code = desk.current_code().code
    try:
        desk.join(code, client="10.0.0.1")
        desk.join(code, client="10.0.0.2")
        with pytest.raises(WrongCode, match="rotate"):
            desk.join(code, client="10.0.0.3")
        assert desk.join(desk.rotate().code, client="10.0.0.3")
    finally:
        desk.close()


def test_joins_are_rate_limited_per_client(server: BoardServer) -> None:
    assert server.desk is not None
    answers = [call(server, "POST", "/join", {"code": "WRONG-CODE"}, address="10.0.0.9")
               for _ in range(ATTEMPTS_PER_WINDOW + 1)]
    assert [status for status, _ in answers[:-1]] == [403] * ATTEMPTS_PER_WINDOW
    assert answers[-1][0] == 429 and answers[-1][1]["error"] == "TooSoon"
    result = server.handle_event(http_event("POST", "/join", {"Content-Type": "application/json"},
                                            json.dumps({"code": server.desk.current_code().code}).encode(),
                                            "10.0.0.9"))
    assert result["statusCode"] == 429 and int(result["headers"]["Retry-After"]) > 0
    assert call(server, "POST", "/join", {"code": server.desk.current_code().code},
                address="10.0.0.10")[0] == 201, "another client still joins"


def test_a_join_expires_and_renewing_it_keeps_the_sign_in_and_alias(server: BoardServer,
                                                                    clock: Clock) -> None:
    assert server.desk is not None
    ada = join(server)
    assert push(server, "Ada", ada)[0] == 201
    clock.now += timedelta(hours=13)
    assert push(server, "Ada", ada, ms=8900)[0] == 401
    status, renewed = call(server, "POST", "/join", {"code": server.desk.current_code().code},
                           token=ada)
    assert status == 201 and renewed["renewed"] is True
    assert push(server, "Ada", renewed["token"], ms=8900)[0] == 201


def test_the_organiser_revokes_a_racer_by_alias(server: BoardServer) -> None:
    assert server.desk is not None
    ada, bob = join(server), join(server)
    assert push(server, "Ada", ada)[0] == 201
    assert push(server, "Bob", bob, ms=9500)[0] == 201
    [revoked] = server.desk.revoke("ada")
    assert revoked.alias == "Ada"
    assert push(server, "Ada", ada, ms=8000)[0] == 401
    status, again = call(server, "POST", "/join", {"code": server.desk.current_code().code},
                         token=ada)
    assert status == 201 and again["renewed"] is False, "a revoked sign-in is not renewed"
    assert push(server, "Ada", again["token"], ms=8000)[1]["error"] == "AliasTaken"
    assert push(server, "Bob", bob, ms=9400)[0] == 201
    listed = {racer.alias: racer for racer in server.desk.joined()}
    assert listed["Ada"].revoked and not listed["Bob"].revoked


def test_the_pages_show_the_network_address_and_code_even_opened_as_localhost(
        server: BoardServer) -> None:
    assert server.desk is not None
    server.public_url = "http://192.168.1.20:8000"
    push(server, "Ada", join(server))
    code = server.desk.current_code().code
    result = server.handle_event(http_event("GET", "/boards/reInvent2019_track/view?screen=1",
                                            {"Host": "localhost:8000"}, b"", "127.0.0.1"))
    page = result["body"]
    assert f"drboard join <strong>{code}</strong> --endpoint http://192.168.1.20:8000" in page
    assert f"QR code: http://192.168.1.20:8000/join?code={code}" in page
    assert "localhost" not in page and "127.0.0.1" not in page
    joining = server.handle_event(http_event("GET", f"/join?code={code}", {}, b"", LAN))
    assert joining["statusCode"] == 200
    assert f"drboard join {code} --endpoint http://192.168.1.20:8000" in joining["body"]


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
    from drboard_cli import render
    from drboard_functions.models.domain import AuditEvent

    row = render.audit_detail(AuditEvent.model_validate(event | {"board_id": "reInvent2019_track"}))
    assert row.startswith("model ")
    assert render.actor_label(event["actor"], event["actor_name"], "Ada") == "Ada (joined)"


def test_drboard_join_saves_a_token_only_its_owner_can_read(server: BoardServer) -> None:
    import threading

    from click.testing import CliRunner
    from drboard_cli.main import cli

    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}"
        assert server.desk is not None
        code = server.desk.current_code().code
        result = CliRunner().invoke(cli, ["join", code, "--endpoint", url])  # as serve prints it
        assert result.exit_code == 0, result.output
        saved = tokens.load(url)
        assert saved is not None and saved.kind == "join"
        assert oct(os.stat(tokens.tokens_path()).st_mode & 0o777) == "0o600"
        from drboard_cli import config

        assert config.load_settings()["endpoint"] == url, "the joined board is the racer's board"
        pushed = CliRunner().invoke(cli, ["push", str(EXAMPLE)])  # the next thing a racer types
        assert pushed.exit_code == 0, pushed.output
        assert f"Pushed to the board at {url}." in pushed.stderr
        again = CliRunner().invoke(cli, ["--endpoint", url, "join", code])  # the global form
        assert again.exit_code == 0 and "Renewed" in again.output
        assert tokens.load(url).username == saved.username  # type: ignore[union-attr]
        wrong = CliRunner().invoke(cli, ["join", "WRONG-CODE", "--endpoint", url])
        assert wrong.exit_code == 1 and "join code is wrong" in wrong.output
        odd = CliRunner().invoke(cli, ["join", "ÄÄÄÄ", "--endpoint", url])
        assert odd.exit_code == 2, odd.output
    finally:
        server.shutdown()
