"""`drboard serve` in its own process, driven by the real `drboard` command and its HTTP client
(``HttpBoard``) over HTTP; and its organiser guard, in-process."""

from __future__ import annotations

import json
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import urllib.error
import urllib.request
from collections.abc import Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any, ClassVar

import pytest
from drboard_cli import tokens
from drboard_cli.remote import HttpBoard
from drboard_cli.serve import BoardServer, http_event
from drboard_functions import errors
from drboard_functions.models.requests import BoardChanges, BoardSpec, ImportedSubmission
from drboard_functions.models.transfer import ExportedBoard, ExportedSubmission, ExportLine

from tests.integration.dynamodb_local import DynamoDbLocal
from tests.recordkit import make_record
from tests.tablekit import create_board_table

ROOT = Path(__file__).parents[2]
EXAMPLES = sorted(str(p) for p in (ROOT / "examples").iterdir() if p.is_dir())
DRBOARD = [sys.executable, "-m", "drboard_cli"]
READY = re.compile(r"on (http://\S+)")


class Served:
    def __init__(self, process: subprocess.Popen[str], url: str, env: dict[str, str]) -> None:
        self.process = process
        self.url = url
        self.env = env

    def drboard(self, *args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
        result = subprocess.run([*DRBOARD, "--endpoint", self.url, *args], env=self.env,
                                capture_output=True, text=True, timeout=60)
        if check:
            assert result.returncode == 0, result.stderr
        return result

    def post(self, path: str, body: bytes) -> tuple[int, Any]:
        request = urllib.request.Request(self.url + path, data=body, method="POST",
                                         headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=30) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as error:
            return error.code, json.loads(error.read())

    def stop(self) -> int:
        self.process.send_signal(signal.SIGINT)  # what Ctrl-C sends
        return self.process.wait(timeout=30)


def _environment(tmp_path: Path) -> dict[str, str]:
    env = {key: value for key, value in os.environ.items()
           if not key.startswith(("DRBOARD_", "XDG_"))}
    env |= {"XDG_DATA_HOME": str(tmp_path / "data"), "XDG_CONFIG_HOME": str(tmp_path / "config"),
            "PYTHONUNBUFFERED": "1", "COLUMNS": "160"}
    return env


def _serve(tmp_path: Path, *options: str, db: Path | None = None) -> Served:
    env = _environment(tmp_path)
    board = ["--db", str(db)] if db else []
    process = subprocess.Popen([*DRBOARD, *board, "serve", "--port", "0", *options], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert process.stdout is not None
    line = process.stdout.readline()
    match = READY.search(line)
    if not match:
        process.kill()
        pytest.fail(f"drboard serve did not start: {line!r}")
    if "--host" not in options:
        assert match.group(1).startswith("http://127.0.0.1:"), "serve listens on loopback by default"
    return Served(process, match.group(1), env)


@pytest.fixture
def served_on_dynamodb(tmp_path: Path, dynamodb_local: DynamoDbLocal) -> Iterator[Served]:
    table = create_board_table(dynamodb_local.client(), f"e2e-{tmp_path.name}")
    served = _serve(tmp_path, "--table", table, "--endpoint-url", dynamodb_local.endpoint)
    yield served
    if served.process.poll() is None:
        served.stop()


@pytest.fixture(params=["sqlite", "dynamodb"])
def served_board(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Served]:
    """`drboard serve` of the embedded board, then of a DynamoDB Local table."""
    if request.param == "dynamodb":
        yield request.getfixturevalue("served_on_dynamodb")
        return
    served = _serve(tmp_path, db=tmp_path / "event.db")
    yield served
    if served.process.poll() is None:
        served.stop()


def test_racers_push_pull_and_look_up_over_http(served_on_dynamodb: Served) -> None:
    served = served_on_dynamodb
    pushed = served.drboard("push", *EXAMPLES)
    assert pushed.stdout.count("new best") == len(EXAMPLES)

    standings = json.loads(served.drboard("pull", "--track", "reInvent2019", "--format", "json").stdout)
    entries = standings["entries"]
    assert entries[0]["rank"] == 1 and entries[0]["gap_ms"] == 0
    qualified = [e["time_ms"] for e in entries if e["qualified"]]
    assert qualified == sorted(qualified)
    leader = entries[0]["racer"]

    again = served.drboard("push", EXAMPLES[0])
    assert "already on the board" in again.stdout

    history = json.loads(served.drboard("history", "--racer", leader, "--format", "json").stdout)
    assert [item["is_best"] for item in history] == [True]

    shown = json.loads(served.drboard("show", leader, "--track", "reInvent2019", "--format",
                                      "json").stdout)
    assert shown["entry"]["rank"] == 1
    assert shown["record"]["design"]["action_space"]

    boards = json.loads(served.drboard("boards", "--format", "json").stdout)
    assert {b["board_id"] for b in boards} >= {"reInvent2019_track"}


def test_a_tampered_record_is_refused_with_field_detail(served_on_dynamodb: Served) -> None:
    served = served_on_dynamodb
    record = json.loads(subprocess.run([*DRBOARD, "assemble", EXAMPLES[0]], env=served.env,
                                       capture_output=True, text=True, check=True).stdout)
    record["evaluations"][0]["laps"][0]["time_ms"] -= 1000  # a faster lap than the files show
    status, answer = served.post(f"/boards/{record['track']}/submissions",
                                 json.dumps(record).encode())
    assert status == 422
    assert answer["detail"], answer
    listed = json.loads(served.drboard("boards", "--format", "json").stdout)
    assert listed == [], "nothing was written"


def test_an_unknown_racer_is_a_failure_not_a_crash(served_on_dynamodb: Served) -> None:
    served = served_on_dynamodb
    served.drboard("push", EXAMPLES[0])
    result = served.drboard("show", "Nobody", "--track", "reInvent2019", check=False)
    assert result.returncode == 1
    assert "Traceback" not in result.stderr


def test_ctrl_c_stops_serve_and_keeps_every_answered_push(tmp_path: Path) -> None:
    board = tmp_path / "event.db"
    served = _serve(tmp_path, db=board)
    served.drboard("push", *EXAMPLES[:3])
    assert served.stop() == 0
    local = subprocess.run([*DRBOARD, "--db", str(board), "pull", "--track", "reInvent2019",
                            "--format", "json"], env=served.env, capture_output=True, text=True,
                           check=True)
    assert len(json.loads(local.stdout)["entries"]) == 3


def _until_the_join_line(served: Served) -> str:
    """What serve printed after its first line, up to the join command racers type; then waits
    until it answers (a Ctrl-C in its first milliseconds, before it serves, is not what this
    checks)."""
    assert served.process.stdout is not None
    printed = []
    while not printed or "Racers join with" not in printed[-1]:
        printed.append(served.process.stdout.readline())
    with urllib.request.urlopen(served.url + "/", timeout=30) as answer:
        assert answer.status == 200
    return "".join(printed)


def test_serving_a_board_that_is_not_there_tells_the_organiser(tmp_path: Path) -> None:
    """A named board that does not exist yet would refuse every racer the join line sends to
    it; a track's own board is made by its first push and needs no word."""
    missing = _serve(tmp_path, "--board", "club-night", db=tmp_path / "event.db")
    try:
        printed = _until_the_join_line(missing)
    finally:
        missing.stop()
    assert "No board 'club-night' here yet" in printed
    assert "drboard board create club-night --track TRACK --title TITLE" in printed
    track = _serve(tmp_path, "--board", "reInvent2019_track", db=tmp_path / "event.db")
    try:
        printed = _until_the_join_line(track)
    finally:
        track.stop()
    assert "No board" not in printed and "--board reInvent2019_track" in printed


# ---- organisers, over HTTP with the CLI's own client --------------------------------------------


def _export(board: HttpBoard, board_id: str) -> tuple[list[ExportLine], int]:
    lines: list[ExportLine] = []
    cursor: str | None = None
    pages = 0
    while True:
        page = board.export_page(board_id, cursor)
        lines += page.lines
        pages += 1
        cursor = page.next_cursor
        if cursor is None:
            return lines, pages


def test_an_export_and_an_import_go_over_http_line_for_line(served_board: Served,
                                                            tmp_path: Path) -> None:
    served_board.drboard("push", *EXAMPLES[:3])
    exported = served_board.drboard("export", "reInvent2019_track").stdout.splitlines()
    paged, _ = _export(HttpBoard(served_board.url), "reInvent2019_track")
    assert exported[1:] == [line.model_dump_json() for line in paged[1:]]
    assert [json.loads(line)["kind"] for line in exported] == ["board"] + ["entry"] * 3 + [
        "submission"] * 3
    copy = tmp_path / "copy.jsonl"
    copy.write_text("\n".join(exported) + "\n")
    served_board.drboard("import", str(copy), "--board", "smile-copy")
    pull = ("pull", "--board", "{}", "--format", "json")
    entries = [json.loads(served_board.drboard(*(a.format(board) for a in pull)).stdout)["entries"]
               for board in ("smile-copy", "reInvent2019_track")]
    assert [e["racer"] for e in entries[0]] == [e["racer"] for e in entries[1]]


def test_an_organiser_runs_a_cup_over_http(served_board: Served) -> None:
    board = HttpBoard(served_board.url)  # signs organiser calls with the (dummy) AWS credentials
    cup = board.create_board(BoardSpec(board_id="winter-cup", title="Winter Cup",
                                       track="Smile Speedway", cooldown_s=3600))
    assert (cup.board_id, cup.track, cup.cooldown_s, cup.status) == (
        "winter-cup", "reInvent2019_track", 3600, "OPEN")
    with pytest.raises(errors.BoardExists):
        board.create_board(BoardSpec(board_id="winter-cup", title="Again", track="reInvent2019"))

    first, second = make_record("Ada", [(13000, 100)]), make_record("Ada", [(12000, 100)])
    assert board.push(first, "winter-cup").status == "created"
    with pytest.raises(errors.TooSoon) as too_soon:
        board.push(second, "winter-cup")
    assert 3500 < too_soon.value.retry_after_s <= 3600
    assert board.push(first, "winter-cup").status == "duplicate"
    [standing] = board.status("ada", "winter-cup").boards
    assert standing.next_submission_at is not None and standing.submissions == 1

    changed = board.update_board("winter-cup", BoardChanges.model_validate({"cooldown_s": None}))
    assert (changed.cooldown_s, changed.title) == (0, "Winter Cup")  # only what was sent changed
    assert board.push(second, "winter-cup").improved
    assert board.push(make_record("Bob", [(12500, 100)]), "winter-cup").rank == 2
    with pytest.raises(errors.BoardLocked):
        board.update_board("winter-cup", BoardChanges(method="TOTAL_TIME"))

    lines, pages = _export(board, "winter-cup")
    assert pages >= 2
    assert isinstance(lines[0], ExportedBoard)
    copy = lines[0].board.model_copy(update={"board_id": "winter-cup-replay"})
    view, created = board.import_board(copy)
    assert (view.board_id, created) == ("winter-cup-replay", True)
    assert board.import_board(copy)[1] is False
    receipts = [board.import_submission("winter-cup-replay", ImportedSubmission(
                    submitted_at=line.submission.submitted_at, record=line.record))
                for line in lines if isinstance(line, ExportedSubmission)]
    assert [r.status for r in receipts] == ["created"] * 3

    def standings(board_id: str) -> list[tuple[int, str, int | None]]:
        return [(e.rank, e.racer, e.time_ms) for e in board.board_page(board_id, 100, None).entries]

    assert standings("winter-cup-replay") == standings("winter-cup") == [
        (1, "Ada", 12000), (2, "Bob", 12500)]
    history = board.history("Ada", None)
    assert [(h.board_id, h.is_best) for h in history if h.board_id == "winter-cup"] == [
        ("winter-cup", False), ("winter-cup", True)]
    assert {h.board_id for h in history} == {"winter-cup", "winter-cup-replay"}

    assert board.close_board("winter-cup").status == "CLOSED"
    with pytest.raises(errors.BoardClosed):
        board.push(make_record("Cleo"), "winter-cup")
    assert board.delete_board("winter-cup-replay").board_id == "winter-cup-replay"
    with pytest.raises(errors.BoardNotFound):
        board.board_page("winter-cup-replay", 10, None)
    assert board.restore_board("winter-cup-replay").participants == 2


def test_a_racer_past_the_boards_maximum_is_told_so(served_board: Served) -> None:
    board = HttpBoard(served_board.url)
    board.create_board(BoardSpec(board_id="one-shot", title="One shot", track="reInvent2019",
                                 max_submissions=1))
    board.push(make_record("Ada", [(13000, 100)]), "one-shot")
    with pytest.raises(errors.SubmissionLimitReached):
        board.push(make_record("Ada", [(12000, 100)]), "one-shot")
    assert board.status("Ada", None).boards[0].submissions_left == 0


def _lan_address() -> str | None:
    """This computer's address on its network, if it has one (nothing is sent)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))  # TEST-NET-1: a route is looked up, no packet leaves
            address = str(probe.getsockname()[0])
        except OSError:
            return None
    return None if address.startswith("127.") else address


def test_organiser_routes_answer_only_the_serving_computer(tmp_path: Path) -> None:
    address = _lan_address()
    if address is None:
        pytest.skip("this computer has no network address other than loopback")
    served = _serve(tmp_path, "--host", "0.0.0.0", db=tmp_path / "event.db")
    try:
        port = served.url.rsplit(":", 1)[1]
        here = HttpBoard(f"http://127.0.0.1:{port}")
        from_the_lan = HttpBoard(f"http://{address}:{port}")
        here.create_board(BoardSpec(board_id="club-night", title="Club night", track="reInvent2019"))
        with pytest.raises(errors.NotAuthorized, match="only on the computer running"):
            from_the_lan.create_board(BoardSpec(board_id="mine", title="Mine", track="reInvent2019"))
        with pytest.raises(errors.NotAuthorized):
            from_the_lan.export_page("club-night", None)
        with pytest.raises(errors.NotAuthorized):
            from_the_lan.delete_board("club-night")
        with pytest.raises(errors.NotSignedIn):
            from_the_lan.push(make_record("Ada"), "club-night")
        assert served.process.stdout is not None
        printed = ""
        while "drboard join" not in printed:
            printed = served.process.stdout.readline()
            assert printed, "serve prints the join command"
        code = re.search(r"drboard join (\S+) --endpoint (\S+)", printed)
        assert code, "serve prints the join command as racers type it"
        assert "0.0.0.0" not in code.group(2) and code.group(2) == served.url, "its network address"
        joined = from_the_lan.join(code.group(1))
        tokens.save(from_the_lan.endpoint, tokens.SavedToken(kind="join", access_token=joined.token))
        assert from_the_lan.push(make_record("Ada"), "club-night").status == "created"  # racers may
        with pytest.raises(errors.AliasTaken):
            from_the_lan.push(make_record("Bob"), "club-night")
        assert [b.board_id for b in from_the_lan.boards()] == ["club-night"]
    finally:
        served.stop()


# ---- the organiser guard, in-process -----------------------------------------------------------


def _from(server: BoardServer, address: str, method: str, path: str,
          body: dict[str, Any] | None = None) -> tuple[int, dict[str, Any]]:
    data = json.dumps(body).encode() if body is not None else b""
    result = server.handle_event(http_event(method, path, {"Content-Type": "application/json"}, data,
                                            address))
    return int(result["statusCode"]), json.loads(result["body"] or "{}")


SPEC = {"board_id": "club-night", "title": "Club night", "track": "reInvent2019"}


@pytest.mark.parametrize("address", ["192.168.1.20", "10.0.0.7", "::ffff:192.168.1.20", "fe80::1",
                                     "not-an-address"])
@pytest.mark.parametrize(("method", "path", "body"), [
    ("POST", "/boards", SPEC), ("PATCH", "/boards/club-night", {"title": "Mine"}),
    ("POST", "/boards/club-night/close", None), ("DELETE", "/boards/club-night", None),
    ("POST", "/boards/club-night/restore", None), ("GET", "/boards/club-night/export", None),
    ("PUT", "/boards/club-night/import", {"board_id": "club-night"}),
    ("POST", "/boards/club-night/imports", {}),
])
def test_another_computer_gets_403_for_every_organiser_route(
        server: BoardServer, address: str, method: str, path: str, body: dict[str, Any] | None) -> None:
    assert _from(server, "127.0.0.1", "POST", "/boards", SPEC)[0] == 201
    status, answer = _from(server, address, method, path, body)
    assert status == 403
    assert answer["error"] == "NotAuthorized"
    assert server.service.boards()[0].title == "Club night"  # nothing changed


@pytest.mark.parametrize("address", ["127.0.0.1", "127.8.9.10", "::1", "::ffff:127.0.0.1"])
def test_the_serving_computer_is_the_organiser(server: BoardServer, address: str) -> None:
    assert _from(server, address, "POST", "/boards", SPEC)[0] == 201
    assert _from(server, address, "PATCH", "/boards/club-night", {"title": "Renamed"})[0] == 200


def test_another_computer_cannot_reach_an_organiser_route_by_another_spelling(
        server: BoardServer) -> None:
    _from(server, "127.0.0.1", "POST", "/boards", SPEC)
    for path in ("/boards/club-night/", "/boards//club-night", "/boards/club-night/export/"):
        status, _ = _from(server, "192.168.1.20", "DELETE" if "export" not in path else "GET", path)
        assert status in (403, 404), path
    assert [b.board_id for b in server.service.boards()] == ["club-night"]


def test_serve_answers_patch_put_and_delete_over_http(server: BoardServer) -> None:
    board = HttpBoard(f"http://127.0.0.1:{server.server_address[1]}")
    board.create_board(BoardSpec.model_validate(SPEC))
    assert board.update_board("club-night", BoardChanges(title="Renamed")).title == "Renamed"
    assert board.delete_board("club-night").board_id == "club-night"
    assert board.restore_board("club-night").title == "Renamed"
    exported = board.export_page("club-night", None).lines[0]
    assert isinstance(exported, ExportedBoard)
    copy = exported.board.model_copy(update={"board_id": "club-night-2"})
    assert board.import_board(copy)[1] is True


# ---- the CLI's client against the answers API Gateway gives itself -------------------------------


class _Gateway(BaseHTTPRequestHandler):
    """Answers every request with the canned answer for its path; remembers what was asked."""

    answers: ClassVar[dict[str, tuple[int, dict[str, str], bytes]]] = {}
    seen: ClassVar[list[tuple[str, str, str | None]]] = []

    def _answer(self) -> None:
        length = int(self.headers.get("Content-Length") or 0)
        self.rfile.read(length)
        self.seen.append((self.command, self.path, self.headers.get("Authorization")))
        status, headers, body = self.answers[self.path.split("?")[0]]
        self.send_response(status)
        for name, value in headers.items():
            self.send_header(name, value)
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    do_GET = do_POST = do_PATCH = do_PUT = do_DELETE = _answer

    def log_message(self, format: str, *args: Any) -> None:
        pass


@pytest.fixture
def gateway() -> Iterator[tuple[str, type[_Gateway]]]:
    handler = type("Gateway", (_Gateway,), {"answers": {}, "seen": []})
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}", handler
    server.shutdown()
    server.server_close()


def _json_answer(status: int, body: dict[str, Any], **headers: str) -> tuple[int, dict[str, str], bytes]:
    return status, {"Content-Type": "application/json", **headers}, json.dumps(body).encode()


def test_the_client_reads_gateway_refusals_and_named_errors(
        gateway: tuple[str, type[_Gateway]]) -> None:
    url, handler = gateway
    handler.answers |= {
        "/boards": _json_answer(403, {"message": "Forbidden"}),  # API Gateway: not signed
        "/boards/cup/submissions": _json_answer(429, {"message": "Too Many Requests"}),  # throttled
        "/boards/cup/close": _json_answer(409, {"error": "BoardLocked", "message": "a default board",
                                                "detail": []}),
        "/boards/cup/export": (502, {"Content-Type": "text/plain"}, b"Bad Gateway"),
        "/racers/Ada": _json_answer(403, {"error": "BoardClosed", "message": "closed", "detail": []}),
    }
    board = HttpBoard(url)
    with pytest.raises(errors.NotAuthorized, match="signed with AWS credentials"):
        board.create_board(BoardSpec.model_validate(SPEC))
    with pytest.raises(errors.TooSoon) as throttled:
        board.push(make_record(), "cup")
    assert throttled.value.retry_after_s == 60
    with pytest.raises(errors.BoardLocked, match="a default board"):
        board.close_board("cup")
    with pytest.raises(errors.BoardUnreachable):
        board.export_page("cup", None)
    with pytest.raises(errors.BoardClosed):
        board.status("Ada", None)
    signed = {(method, path.split("?")[0]): auth is not None for method, path, auth in handler.seen}
    assert signed == {("POST", "/boards"): True, ("POST", "/boards/cup/submissions"): True,
                      ("POST", "/boards/cup/close"): True, ("GET", "/boards/cup/export"): True,
                      ("GET", "/racers/Ada"): False}, "organiser calls and pushes are signed; reads not"
