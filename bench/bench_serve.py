#!/usr/bin/env python3
"""Load figures of `drboard serve` over HTTP, beside a bare server's floor.

Not a test: it seeds a board, starts `drboard serve` and a floor server on 127.0.0.1, drives
both with keep-alive clients and prints one table. See bench/README.md.

    python bench/bench_serve.py                   # 1,000 racers; 1, 8 and 32 clients; 3 s each
    python bench/bench_serve.py --seconds 1       # shorter
    python bench/bench_serve.py --json figures.json

Standard library, uvicorn (the floor) and the drboard packages themselves.
"""

from __future__ import annotations

import argparse
import http.client
import json
import os
import platform
import random
import re
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict, dataclass
from datetime import UTC, datetime
from pathlib import Path

from bench_local import BOARD_ID, RecordFactory, seed_board

READY = re.compile(r"on (http://\S+)")
PATHS = {"board JSON": f"/boards/{BOARD_ID}?limit=100", "board page": f"/boards/{BOARD_ID}/view"}
STALLED_CONNECTIONS = 100

#: A floor: uvicorn serving fixed bytes (the same sizes as drboard's answers) from a trivial
#: ASGI application, in a process of its own as drboard's is. Prints its port, then serves.
FLOOR_SERVER = """
import socket, sys, uvicorn
bodies = {"json": open(sys.argv[1], "rb").read(), "page": open(sys.argv[2], "rb").read()}
types = {"json": b"application/json", "page": b"text/html; charset=utf-8"}

async def app(scope, receive, send):
    if scope["type"] != "http":
        return
    kind = "page" if scope["path"].endswith("/view") else "json"
    await send({"type": "http.response.start", "status": 200, "headers": [
        (b"content-type", types[kind]), (b"content-length", str(len(bodies[kind])).encode())]})
    await send({"type": "http.response.body", "body": bodies[kind]})

sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM, socket.IPPROTO_TCP)  # so: TCP_NODELAY
sock.bind(("127.0.0.1", 0))
sock.listen(1024)
print(sock.getsockname()[1], flush=True)
config = uvicorn.Config(app, http="h11", loop="asyncio", lifespan="off", log_config=None,
                        access_log=False, backlog=1024)
uvicorn.Server(config).run(sockets=[sock])
"""


@dataclass
class Load:
    requests_per_s: float
    p50_ms: float
    p99_ms: float
    errors: int


@dataclass
class Row:
    request: str
    clients: int
    drboard: Load
    floor: Load

    @property
    def ratio(self) -> float:
        return self.drboard.requests_per_s / self.floor.requests_per_s if self.floor.requests_per_s else 0.0


def _get(connection: http.client.HTTPConnection, path: str) -> bytes:
    connection.request("GET", path)
    response = connection.getresponse()
    body = response.read()
    if response.status != 200:
        raise http.client.HTTPException(f"{path} answered {response.status}")
    return body


def load(port: int, path: str, clients: int, seconds: float) -> Load:
    """``clients`` threads, each on one keep-alive connection, asking ``path`` for ``seconds``."""
    latencies: list[float] = []
    errors = [0]
    ready = threading.Barrier(clients + 1)
    window: list[float] = []
    lock = threading.Lock()

    def client() -> None:
        connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        _get(connection, path)  # connected and warm before the window opens
        mine, failed = [], 0
        ready.wait()
        deadline = window[0]
        while (start := time.perf_counter()) < deadline:
            try:
                _get(connection, path)
                mine.append(time.perf_counter() - start)
            except (OSError, http.client.HTTPException):
                failed += 1
                connection.close()
                connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
        connection.close()
        with lock:
            latencies.extend(mine)
            errors[0] += failed

    threads = [threading.Thread(target=client) for _ in range(clients)]
    for thread in threads:
        thread.start()
    start = time.perf_counter()
    window.append(start + seconds)
    ready.wait()
    for thread in threads:
        thread.join()
    elapsed = max(time.perf_counter() - start, seconds)
    cuts = statistics.quantiles(latencies, n=100, method="inclusive") if len(latencies) > 1 else [0.0] * 99
    return Load(len(latencies) / elapsed, cuts[49] * 1000, cuts[98] * 1000, errors[0])


def _port_of(url: str) -> int:
    return int(url.rsplit(":", 1)[1])


def start_drboard(db: Path, workdir: Path) -> tuple[subprocess.Popen[str], int]:
    env = {key: value for key, value in os.environ.items() if not key.startswith(("DRBOARD_", "XDG_"))}
    env |= {"XDG_DATA_HOME": str(workdir / "data"), "XDG_CONFIG_HOME": str(workdir / "config"),
            "PYTHONUNBUFFERED": "1"}
    process = subprocess.Popen([sys.executable, "-m", "drboard_cli", "--db", str(db), "serve", "--port", "0"],
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert process.stdout is not None
    match = READY.search(process.stdout.readline())
    if not match:
        process.kill()
        raise SystemExit("drboard serve did not start")
    return process, _port_of(match.group(1))


def start_floor(json_body: Path, page_body: Path) -> tuple[subprocess.Popen[str], int]:
    process = subprocess.Popen([sys.executable, "-c", FLOOR_SERVER, str(json_body), str(page_body)],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert process.stdout is not None
    return process, int(process.stdout.readline())


def stop(process: subprocess.Popen[str]) -> None:
    process.terminate()
    process.wait(timeout=60)


def stalled_connections(port: int, path: str) -> dict[str, float]:
    """Open connections that send nothing: is the server still answering, and does it let them go?"""
    stalled = [socket.create_connection(("127.0.0.1", port)) for _ in range(STALLED_CONNECTIONS)]
    opened = time.perf_counter()
    connection = http.client.HTTPConnection("127.0.0.1", port, timeout=30)
    start = time.perf_counter()
    answered = True
    try:
        _get(connection, path)
    except (OSError, http.client.HTTPException):
        answered = False
    answer_ms = (time.perf_counter() - start) * 1000
    connection.close()
    closed, last_closed = 0, 0.0
    for sock in stalled:
        sock.settimeout(max(0.1, opened + 30 - time.perf_counter()))
        try:
            gone = sock.recv(1) == b""
        except TimeoutError:
            gone = False
        except ConnectionResetError:
            gone = True
        if gone:
            closed += 1
            last_closed = time.perf_counter() - opened
        sock.close()
    return {"stalled": STALLED_CONNECTIONS, "answered_meanwhile": float(answered),
            "answer_ms": answer_ms, "closed_by_server": closed, "last_closed_after_s": last_closed}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--racers", type=int, default=1000, help="racers on the seeded board (default 1000)")
    parser.add_argument("--clients", type=int, nargs="+", default=[1, 8, 32],
                        help="concurrency levels (default 1 8 32)")
    parser.add_argument("--seconds", type=float, default=3.0,
                        help="timed window per server, request and level (default 3)")
    parser.add_argument("--seed", type=int, default=2019, help="random seed (default 2019)")
    parser.add_argument("--json", metavar="FILE", type=Path, help="also save the figures here")
    return parser.parse_args(argv)


def measure(args: argparse.Namespace, workdir: Path) -> tuple[list[Row], dict[str, float]]:
    db = workdir / "board.db"
    print(f"seeding {args.racers:,} racers ...", file=sys.stderr, flush=True)
    seed_board(db, args.racers, RecordFactory(random.Random(args.seed)))
    drboard, drboard_port = start_drboard(db, workdir)
    try:
        connection = http.client.HTTPConnection("127.0.0.1", drboard_port, timeout=30)
        bodies = {name: _get(connection, path) for name, path in PATHS.items()}
        connection.close()
        (workdir / "board.json").write_bytes(bodies["board JSON"])
        (workdir / "page.html").write_bytes(bodies["board page"])
        floor, floor_port = start_floor(workdir / "board.json", workdir / "page.html")
        try:
            rows = []
            for name, path in PATHS.items():
                for clients in args.clients:
                    print(f"{name} ({len(bodies[name]):,} bytes), {clients} clients ...",
                          file=sys.stderr, flush=True)
                    rows.append(Row(name, clients, load(drboard_port, path, clients, args.seconds),
                                    load(floor_port, path, clients, args.seconds)))
        finally:
            stop(floor)
        print(f"{STALLED_CONNECTIONS} stalled connections ...", file=sys.stderr, flush=True)
        stalled = stalled_connections(drboard_port, PATHS["board JSON"])
    finally:
        stop(drboard)
    return rows, stalled


def table(rows: list[Row]) -> str:
    header = ("Request", "Clients", "drboard req/s", "p50 ms", "p99 ms", "errors",
              "floor req/s", "p50 ms", "p99 ms", "drboard/floor")
    lines = [header]
    for row in rows:
        d, f = row.drboard, row.floor
        lines.append((row.request, str(row.clients), f"{d.requests_per_s:,.0f}", f"{d.p50_ms:.2f}",
                      f"{d.p99_ms:.2f}", str(d.errors), f"{f.requests_per_s:,.0f}", f"{f.p50_ms:.2f}",
                      f"{f.p99_ms:.2f}", f"{row.ratio:.2f}"))
    widths = [max(len(line[i]) for line in lines) for i in range(len(header))]
    shown = ["  ".join(cell.ljust(w) if i == 0 else cell.rjust(w) for i, (cell, w) in
                       enumerate(zip(line, widths, strict=True))) for line in lines]
    shown.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(shown)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="drboard-bench-serve-") as scratch:
        rows, stalled = measure(args, Path(scratch))
    print()
    print(f"drboard serve under load · {args.racers:,} racers · {args.seconds:g} s per run · "
          f"Python {sys.version.split()[0]} · {platform.platform()} · {os.cpu_count()} CPUs")
    print()
    print(table(rows))
    print()
    print(f"{stalled['stalled']:.0f} stalled connections (connected, nothing sent): "
          f"{'answered' if stalled['answered_meanwhile'] else 'NOT answered'} a pull meanwhile "
          f"in {stalled['answer_ms']:.1f} ms; {stalled['closed_by_server']:.0f} closed by the server, "
          f"the last after {stalled['last_closed_after_s']:.1f} s")
    if args.json:
        args.json.write_text(json.dumps({
            "config": {**vars(args), "json": str(args.json), "python": sys.version.split()[0],
                       "platform": platform.platform(), "cpus": os.cpu_count(),
                       "started_at": datetime.now(UTC).isoformat(timespec="seconds")},
            "rows": [{**asdict(row), "ratio": row.ratio} for row in rows], "stalled": stalled,
        }, indent=2) + "\n")
        print(f"Figures saved to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
