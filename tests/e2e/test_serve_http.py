"""`drboard serve` as an HTTP server: requests answered side by side, connections that idle or
stall let go, the organiser guard on the connection's own address, the body bound, and no
answered push lost when the process is killed."""

from __future__ import annotations

import asyncio
import contextlib
import http.client
import json
import signal
import socket
import sqlite3
import subprocess
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import pytest
from drboard_cli.serve import IDLE_CONNECTION_S, MAX_BODY_BYTES, BoardServer

from tests.e2e.test_serve import DRBOARD, EXAMPLES, _serve
from tests.recordkit import make_record

BOARDS = [f"cup-{number}" for number in range(6)]


def _connect(server: BoardServer) -> http.client.HTTPConnection:
    return http.client.HTTPConnection("127.0.0.1", server.server_address[1], timeout=20)


def _call(connection: http.client.HTTPConnection, method: str, path: str, body: Any = None,
          headers: dict[str, str] | None = None) -> tuple[int, bytes]:
    data = json.dumps(body).encode() if body is not None else None
    connection.request(method, path, body=data,
                       headers={"Content-Type": "application/json", **(headers or {})})
    response = connection.getresponse()
    return response.status, response.read()


def _create_boards(server: BoardServer) -> None:
    connection = _connect(server)
    for board in BOARDS:
        spec = {"board_id": board, "title": f"Title of {board}", "track": "reInvent2019"}
        assert _call(connection, "POST", "/boards", spec)[0] == 201
    connection.close()


def test_clients_side_by_side_each_get_their_own_answer(server: BoardServer) -> None:
    _create_boards(server)

    def client(number: int) -> list[str]:
        connection, problems = _connect(server), []
        for turn in range(15):
            board = BOARDS[(number + turn) % len(BOARDS)]
            status, page = _call(connection, "GET", f"/boards/{board}/view")
            if status != 200 or f"<h1>Title of {board}</h1>" not in page.decode():
                problems.append(f"client {number}: {board} page answered {status} for another request")
            status, answer = _call(connection, "GET", f"/boards/{board}")
            if status != 200 or json.loads(answer)["board"]["title"] != f"Title of {board}":
                problems.append(f"client {number}: {board} answered {status} {answer[:80]!r}")
        connection.close()
        return problems

    with ThreadPoolExecutor(8) as clients:
        problems = [problem for found in clients.map(client, range(8)) for problem in found]
    assert problems == []


def test_a_pull_is_answered_while_a_push_waits_for_the_board(server: BoardServer, tmp_path: Path,
                                                            capfd: pytest.CaptureFixture[str]) -> None:
    _create_boards(server)
    holder = sqlite3.connect(tmp_path / "event.db", isolation_level=None)
    holder.execute("BEGIN IMMEDIATE")  # another program writing the board: pushes wait for it
    pusher = _connect(server)
    record = make_record("Ada", [(9000, 100)]).model_dump(mode="json")
    try:
        pusher.request("POST", f"/boards/{BOARDS[0]}/submissions", body=json.dumps(record).encode(),
                       headers={"Content-Type": "application/json"})
        time.sleep(0.5)  # the push is now waiting on the board's write lock
        puller = _connect(server)
        assert _call(puller, "GET", f"/boards/{BOARDS[1]}?limit=10")[0] == 200
        assert _call(puller, "GET", f"/boards/{BOARDS[0]}/view")[0] == 200
        puller.close()
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    assert pusher.getresponse().status == 201
    pusher.close()
    # The organiser's log tells the push once, as stored: not first as refused by the busy board.
    log = capfd.readouterr().err
    assert log.count("Ada pushed") == 1, log
    assert "refused" not in log, log


def test_pushes_to_a_free_board_are_each_told_once_in_the_log(server: BoardServer,
                                                              capfd: pytest.CaptureFixture[str]) -> None:
    _create_boards(server)
    pusher = _connect(server)
    for number, racer in enumerate(("Ada", "Grace", "Alan")):
        record = make_record(racer, [(9000 + 100 * number, 100)]).model_dump(mode="json")
        assert _call(pusher, "POST", f"/boards/{BOARDS[0]}/submissions", record)[0] == 201
    pusher.close()
    log = capfd.readouterr().err
    assert [line.split("  ", 1)[1].split(":")[0] for line in log.splitlines() if " pushed " in line] == [
        f"{racer} pushed {make_record(racer, [(9000, 100)]).model_name} to {BOARDS[0]}"
        for racer in ("Ada", "Grace", "Alan")]
    assert "rank 3 of 3" in log


def test_event_streams_do_not_hold_up_requests(server: BoardServer) -> None:
    _create_boards(server)
    streams = []
    for board in BOARDS:
        stream = _connect(server)
        stream.request("GET", f"/boards/{board}/events")
        response = stream.getresponse()
        assert response.status == 200
        assert response.readline() == b"retry: 2000\n"
        streams.append(stream)
    connection = _connect(server)
    assert [_call(connection, "GET", f"/boards/{board}")[0] for board in BOARDS] == [200] * len(BOARDS)
    for stream in streams:
        stream.close()


def _closed_by_server(connection: socket.socket, within_s: float) -> bool:
    connection.settimeout(within_s)
    try:
        return connection.recv(1) == b""
    except TimeoutError:
        return False
    except ConnectionResetError:
        return True


@pytest.mark.parametrize("sent", [b"", b"GET /boards HTTP/1.1\r\nHost: x\r\n"],
                         ids=["nothing", "half a request"])
def test_a_stalled_connection_is_closed_and_the_server_answers_meanwhile(
        server: BoardServer, sent: bytes) -> None:
    stalled = [socket.create_connection(("127.0.0.1", server.server_address[1])) for _ in range(20)]
    for connection in stalled:
        connection.sendall(sent)
    assert _call(_connect(server), "GET", "/boards")[0] == 200
    assert all(_closed_by_server(connection, IDLE_CONNECTION_S + 5) for connection in stalled)
    for connection in stalled:
        connection.close()


def test_an_idle_keep_alive_connection_is_closed_after_the_timeout(server: BoardServer) -> None:
    connection = _connect(server)
    assert _call(connection, "GET", "/boards")[0] == 200
    assert connection.sock is not None
    assert not _closed_by_server(connection.sock, 0.5), "kept alive for the next request"
    assert _call(connection, "GET", "/boards")[0] == 200
    assert _closed_by_server(connection.sock, IDLE_CONNECTION_S + 5)


def test_an_oversized_body_is_refused_before_it_is_sent(server: BoardServer) -> None:
    connection = _connect(server)
    connection.putrequest("POST", "/boards/cup-0/submissions")
    connection.putheader("Content-Type", "application/json")
    connection.putheader("Content-Length", str(MAX_BODY_BYTES + 1))
    connection.endheaders()
    response = connection.getresponse()
    assert response.status == 413
    assert "too large" in json.loads(response.read())["message"]


def test_an_oversized_chunked_body_is_refused(server: BoardServer) -> None:
    chunks = (b"x" * 65536 for _ in range(MAX_BODY_BYTES // 65536 + 2))
    connection = _connect(server)
    with contextlib.suppress(BrokenPipeError, ConnectionResetError):  # answered before the last chunk
        connection.request("POST", "/boards/cup-0/submissions", body=chunks, encode_chunked=True,
                           headers={"Content-Type": "application/json"})
    assert connection.getresponse().status == 413


def _asgi_request(server: BoardServer, client: tuple[str, int], method: str, path: str,
                  body: bytes, headers: list[tuple[bytes, bytes]]) -> tuple[int, dict[str, Any]]:
    """One request through the server's ASGI application, as from a peer at this address."""
    scope = {"type": "http", "method": method, "path": path, "raw_path": path.encode(),
             "query_string": b"", "headers": [(b"content-type", b"application/json"), *headers],
             "client": client, "server": ("127.0.0.1", server.server_address[1])}
    messages = [{"type": "http.request", "body": body, "more_body": False}]
    sent: list[dict[str, Any]] = []

    async def receive() -> dict[str, Any]:
        return messages.pop(0) if messages else {"type": "http.disconnect"}

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    asyncio.run(server(scope, receive, send))
    return sent[0]["status"], json.loads(b"".join(m.get("body", b"") for m in sent[1:]))


SPEC = json.dumps({"board_id": "mine", "title": "Mine", "track": "reInvent2019"}).encode()


def test_a_body_that_is_not_utf8_is_refused_saying_so(server: BoardServer) -> None:
    connection = _connect(server)
    connection.request("POST", "/boards", body=b'{"board_id": "cup-\xff"}',
                       headers={"Content-Type": "application/json"})
    response = connection.getresponse()
    answer = json.loads(response.read())
    assert (response.status, answer["error"]) == (400, "UnreadableBody")
    assert "UTF-8" in answer["message"]


def test_a_malformed_content_length_is_a_bad_request_and_the_server_goes_on(
        server: BoardServer) -> None:
    with socket.create_connection(("127.0.0.1", server.server_address[1]), timeout=10) as raw:
        raw.sendall(b"POST /boards HTTP/1.1\r\nHost: x\r\nContent-Length: 12abc\r\n\r\n{}")
        assert raw.recv(1024).startswith(b"HTTP/1.1 400")
    assert _call(_connect(server), "GET", "/boards")[0] == 200


def test_an_organiser_route_from_another_computer_is_403_whatever_its_headers(
        server: BoardServer) -> None:
    claims = [(b"x-forwarded-for", b"127.0.0.1"), (b"forwarded", b"for=127.0.0.1"),
              (b"x-real-ip", b"127.0.0.1"), (b"host", b"127.0.0.1")]
    status, answer = _asgi_request(server, ("192.168.1.20", 50000), "POST", "/boards", SPEC, claims)
    assert (status, answer["error"]) == (403, "NotAuthorized")
    assert server.service.boards() == []


def test_a_forwarding_header_does_not_make_the_serving_computer_a_stranger(
        server: BoardServer) -> None:
    connection = _connect(server)
    status, _ = _call(connection, "POST", "/boards", json.loads(SPEC),
                      headers={"X-Forwarded-For": "192.168.1.20", "Forwarded": "for=192.168.1.20"})
    assert status == 201


def test_killed_serve_keeps_every_answered_push(tmp_path: Path) -> None:
    board = tmp_path / "event.db"
    served = _serve(tmp_path, db=board)
    served.drboard("push", *EXAMPLES[:3])
    served.process.send_signal(signal.SIGKILL)
    served.process.wait(timeout=30)
    local = subprocess.run([*DRBOARD, "--db", str(board), "pull", "--track", "reInvent2019",
                            "--format", "json"], env=served.env, capture_output=True, text=True,
                           check=True)
    assert len(json.loads(local.stdout)["entries"]) == 3


def test_sigterm_stops_serve_cleanly(tmp_path: Path) -> None:
    served = _serve(tmp_path, db=tmp_path / "event.db")
    served.drboard("push", EXAMPLES[0])
    served.process.send_signal(signal.SIGTERM)
    assert served.process.wait(timeout=30) == 0
