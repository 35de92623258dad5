#!/usr/bin/env python3
"""Load figures of `drboard serve` over HTTP, each beside its floor.

Not a test: it seeds a board, starts `drboard serve` and a floor server on 127.0.0.1, drives both
with the same clients in interleaved windows and prints one table. See bench/README.md.

    python bench/bench_serve.py                   # 1,000 racers; 1, 8, 32 clients; ~4 minutes
    python bench/bench_serve.py --seconds 0.5 --rounds 2
    python bench/bench_serve.py --only get --json figures.json

Standard library, uvicorn (the floors) and the drboard packages themselves.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import pickle
import platform
import random
import re
import shutil
import socket
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from bench_local import BOARD_ID, RecordFactory, seed_board

READY = re.compile(r"on (http://\S+)")
STALLED_CONNECTIONS = 100
WARM_UP_PUSHES = 20
#: The standings reads: the board's JSON, its web page, and the JSON asked again with the ETag
#: the client holds (answered 304).
READS = {
    "board JSON": f"/boards/{BOARD_ID}?limit=100",
    "board page": f"/boards/{BOARD_ID}/view",
    "board JSON, 304": f"/boards/{BOARD_ID}?limit=100",
}
PUSH_PATH = f"/boards/{BOARD_ID}/submissions"
TICKS = os.sysconf("SC_CLK_TCK")

#: The floor of the reads and of the pushes: uvicorn (the same server, protocol and settings as
#: drboard's) with a trivial ASGI application, in a process of its own as drboard's is.
#: - A read is answered with the very bytes drboard answered it with (status, headers, body),
#:   from a dict: only the Date header differs.
#: - A push reads its body and parses it as JSON (a server must at least read what it stores),
#:   then runs on the board's SQLite file (a copy of drboard's, WAL, synchronous=NORMAL, one
#:   connection) exactly the statements, with the same parameters, that drboard's store ran for
#:   the same record, in the same transactions, and answers the receipt drboard gave it.
#:   Everything drboard does besides the storage (validating the record, scoring it, the trust
#:   rules, routing, encoding) is what this floor leaves out.
#: - The second push floor ("validate") also validates the body as a Record (the schema and the
#:   checks every board makes: its figures, its submission id, its texts), as any server that
#:   stores what racers send must; it leaves out the scoring, the trust rules and the routing.
FLOOR_SERVER = r"""
import json, pickle, socket, sqlite3, sys, uvicorn
answers = pickle.load(open(sys.argv[1], "rb"))
pushes = pickle.load(open(sys.argv[2], "rb")) if sys.argv[2] != "-" else {}
db = sqlite3.connect(sys.argv[3], isolation_level=None, check_same_thread=False) if pushes else None
if sys.argv[4] == "validate":
    from drboard_assembler.record import Record
    submission_of = lambda body: Record.model_validate_json(body).submission_id
else:
    submission_of = lambda body: json.loads(body)["submission_id"]
if db is not None:
    db.execute("PRAGMA journal_mode=WAL")
    db.execute("PRAGMA synchronous=NORMAL")

async def app(scope, receive, send):
    if scope["type"] != "http":
        return
    body = b""
    more = True
    while more:
        message = await receive()
        body += message.get("body", b"")
        more = message.get("more_body", False)
    if scope["method"] == "POST":
        statements, status, headers, answer = pushes[submission_of(body)]
        for sql, parameters in statements:
            db.execute(sql, parameters).fetchall()
    else:
        held = any(name == b"if-none-match" for name, _ in scope["headers"])
        status, headers, answer = answers[(scope["path"], held)]
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": answer})

sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM, socket.IPPROTO_TCP)  # so: TCP_NODELAY
sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
sock.bind(("127.0.0.1", 0))
sock.listen(1024)
print(sock.getsockname()[1], flush=True)
config = uvicorn.Config(app, http="h11", loop="asyncio", lifespan="off", log_config=None,
                        access_log=False, backlog=1024, server_header=False,
                        timeout_keep_alive=5, limit_concurrency=1000)
uvicorn.Server(config).run(sockets=[sock])
"""


# ---- the clients ------------------------------------------------------------------------------


def request_bytes(method: str, path: str, *, body: bytes = b"", close: bool = False,
                  etag: str | None = None) -> bytes:
    lines = [f"{method} {path} HTTP/1.1", "Host: 127.0.0.1"]
    if etag:
        lines.append(f"If-None-Match: {etag}")
    if body:
        lines += ["Content-Type: application/json", f"Content-Length: {len(body)}"]
    if close:
        lines.append("Connection: close")
    return ("\r\n".join(lines) + "\r\n\r\n").encode() + body


def read_answer(sock: socket.socket, buffer: bytes) -> tuple[int, list[tuple[bytes, bytes]], bytes, bytes]:
    """One HTTP/1.1 answer: status, headers, body, and what followed it."""
    while b"\r\n\r\n" not in buffer:
        chunk = sock.recv(65536)
        if not chunk:
            raise ConnectionError("closed before an answer")
        buffer += chunk
    head, _, rest = buffer.partition(b"\r\n\r\n")
    lines = head.split(b"\r\n")
    status = int(lines[0].split(b" ", 2)[1])
    headers = [(name.strip().lower(), value.strip()) for name, _, value in
               (line.partition(b":") for line in lines[1:])]
    length = next((int(value) for name, value in headers if name == b"content-length"), 0)
    while len(rest) < length:
        chunk = sock.recv(max(65536, length - len(rest)))
        if not chunk:
            raise ConnectionError("closed in the middle of an answer")
        rest += chunk
    return status, headers, rest[:length], rest[length:]


@dataclass
class Job:
    """What one client process does: ``threads`` clients on ``port``, each sending its requests
    (GETs until ``until``; or its list of bodies), on one keep-alive connection or a new
    connection per request."""

    port: int
    threads: int
    fresh: bool
    start_at: float
    until: float = 0.0
    request: bytes = b""  # a read, sent again and again
    expect: int = 200
    bodies: list[list[bytes]] = field(default_factory=list)  # pushes: each thread's


def run_job(job: Job) -> tuple[list[float], int]:
    """Latencies of the requests answered as expected, and the count of the others."""
    latencies: list[float] = []
    errors = [0]
    lock = threading.Lock()

    def client(mine: list[bytes] | None) -> None:
        got: list[float] = []
        failed = 0
        sock: socket.socket | None = None
        buffer = b""
        requests = iter(mine) if mine is not None else None
        while time.monotonic() < job.start_at:
            time.sleep(0.001)
        while True:
            if requests is not None:
                payload = next(requests, None)
                if payload is None:
                    break
            else:
                if time.monotonic() >= job.until:
                    break
                payload = job.request
            start = time.perf_counter()
            try:
                if sock is None:
                    sock = socket.create_connection(("127.0.0.1", job.port), timeout=30)
                    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                    buffer = b""
                sock.sendall(payload)
                status, _, _, buffer = read_answer(sock, buffer)
                if status == job.expect:
                    got.append(time.perf_counter() - start)
                else:
                    failed += 1
                if job.fresh:
                    sock.close()
                    sock = None
            except (OSError, ValueError, IndexError):  # no answer, or not an HTTP one
                failed += 1
                if sock is not None:
                    sock.close()
                sock = None
        if sock is not None:
            sock.close()
        with lock:
            latencies.extend(got)
            errors[0] += failed

    lists: list[list[bytes] | None] = list(job.bodies) if job.bodies else [None] * job.threads
    threads = [threading.Thread(target=client, args=(mine,)) for mine in lists]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return latencies, errors[0]


# ---- the servers ------------------------------------------------------------------------------


@dataclass
class Server:
    name: str
    process: subprocess.Popen[str]
    port: int

    def cpu_s(self) -> float:
        """The server process's CPU time so far (user + system)."""
        fields = Path(f"/proc/{self.process.pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / TICKS

    def stop(self) -> None:
        self.process.terminate()
        self.process.wait(timeout=60)


def start_drboard(db: Path, workdir: Path) -> Server:
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
    return Server("drboard", process, int(match.group(1).rsplit(":", 1)[1]))


def start_floor(answers: Path, pushes: Path | None, db: Path | None, *, validate: bool = False) -> Server:
    process = subprocess.Popen([sys.executable, "-c", FLOOR_SERVER, str(answers),
                                str(pushes) if pushes else "-", str(db) if db else "-",
                                "validate" if validate else "parse"],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert process.stdout is not None
    return Server("floor, validating" if validate else "floor", process, int(process.stdout.readline()))


def fetch(port: int, payload: bytes) -> tuple[int, list[tuple[bytes, bytes]], bytes]:
    with socket.create_connection(("127.0.0.1", port), timeout=30) as sock:
        sock.sendall(payload)
        status, headers, body, _ = read_answer(sock, b"")
    return status, headers, body


Answer = tuple[int, list[tuple[bytes, bytes]], bytes]


def as_served(status: int, headers: list[tuple[bytes, bytes]], body: bytes) -> Answer:
    """An answer as the floor replays it: every header but the Date, which uvicorn adds itself."""
    return status, [(name, value) for name, value in headers if name != b"date"], body


# ---- the push floor's statements ----------------------------------------------------------------


class RecordingConnection(sqlite3.Connection):
    """A connection that notes every statement run on it, with its parameters."""

    log: list[tuple[str, Any]] | None = None

    def execute(self, sql: str, parameters: Any = (), /) -> sqlite3.Cursor:  # type: ignore[override]
        if RecordingConnection.log is not None:
            RecordingConnection.log.append((sql, tuple(parameters)))
        return super().execute(sql, parameters)


def storage_of_pushes(seeded: Path, workdir: Path, records: Sequence[Any]) -> dict[str, Any]:
    """Each push's storage work as drboard's store does it (its statements and parameters), from
    pushing the records in order through the service onto a copy of the seeded board; and the
    receipt each push answered."""
    from drboard_functions.identity import LOCAL_ORGANISER
    from drboard_functions.service import LeaderboardService
    from drboard_functions.stores.sqlite import SqliteStore

    copy = workdir / "capture.db"
    shutil.copyfile(seeded, copy)
    connect = sqlite3.connect
    sqlite3.connect = lambda *a, **k: connect(*a, **k, factory=RecordingConnection)  # type: ignore[assignment]
    try:
        store = SqliteStore(copy)
        service = LeaderboardService(store)
        pushes = {}
        for record in records:
            RecordingConnection.log = []
            receipt = service.push(record, BOARD_ID, caller=LOCAL_ORGANISER)
            statements, RecordingConnection.log = RecordingConnection.log, None
            answer = receipt.model_dump_json().encode()
            pushes[record.submission_id] = (statements, 201 if receipt.status == "created" else 200,
                                            [(b"content-type", b"application/json"),
                                             (b"content-length", str(len(answer)).encode())], answer)
        store.close()
    finally:
        sqlite3.connect = connect  # type: ignore[assignment]
    return pushes


# ---- measuring ------------------------------------------------------------------------------------


@dataclass
class Load:
    requests: int = 0
    seconds: float = 0.0
    cpu_s: float = 0.0
    errors: int = 0
    latencies: list[float] = field(default_factory=list, repr=False)

    @property
    def per_s(self) -> float:
        return self.requests / self.seconds if self.seconds else 0.0

    @property
    def cpu_us(self) -> float:
        """The server's CPU per answered request, µs."""
        return self.cpu_s / self.requests * 1e6 if self.requests else 0.0

    def quantile_ms(self, q: int) -> float:
        if len(self.latencies) < 2:
            return 0.0
        return statistics.quantiles(self.latencies, n=100, method="inclusive")[q - 1] * 1000


@dataclass
class Row:
    request: str
    connections: str
    clients: int
    drboard: Load
    floor: Load

    @property
    def ratio(self) -> float:
        """drboard's requests per second over the floor's."""
        return self.drboard.per_s / self.floor.per_s if self.floor.per_s else 0.0

    @property
    def cpu_ratio(self) -> float:
        """The floor's CPU per request over drboard's (the server's own share)."""
        return self.floor.cpu_us / self.drboard.cpu_us if self.drboard.cpu_us else 0.0


def window(server: Server, job: Job, processes: int, load: Load) -> None:
    """One timed window of ``job`` against ``server``, split over client processes."""
    per_process = [job.threads // processes + (1 if p < job.threads % processes else 0)
                   for p in range(processes)]
    jobs = []
    for p, threads in enumerate(per_process):
        if not threads:
            continue
        part = Job(**{**asdict(job), "port": server.port, "threads": threads})
        if job.bodies:
            part.bodies = job.bodies[p::processes]
        jobs.append(part)
    with ProcessPoolExecutor(len(jobs), mp_context=multiprocessing.get_context("fork")) as pool:
        futures = [pool.submit(run_job, part) for part in jobs]
        while time.monotonic() < job.start_at:
            time.sleep(0.001)
        cpu, start = server.cpu_s(), time.monotonic()
        results = [future.result() for future in futures]
        elapsed, used = time.monotonic() - start, server.cpu_s() - cpu
    load.seconds += elapsed
    load.cpu_s += used
    for latencies, errors in results:
        load.requests += len(latencies)
        load.latencies.extend(latencies)
        load.errors += errors


def measure_reads(args: argparse.Namespace, servers: dict[str, Server], etags: dict[str, str]) -> list[Row]:
    rows = []
    for name, path in READS.items():
        held = name.endswith("304")
        for fresh in (False, True):
            for clients in args.clients:
                print(f"{name}, {'new connections' if fresh else 'keep-alive'}, {clients} clients ...",
                      file=sys.stderr, flush=True)
                loads = {"drboard": Load(), "floor": Load()}
                request = request_bytes("GET", path, close=fresh, etag=etags[path] if held else None)
                for _ in range(args.rounds):
                    for server in servers.values():  # interleaved: drboard, floor, drboard, ...
                        start_at = time.monotonic() + 0.3
                        job = Job(port=server.port, threads=clients, fresh=fresh, start_at=start_at,
                                  until=start_at + args.seconds, request=request,
                                  expect=304 if held else 200)
                        window(server, job, min(clients, args.client_processes), loads[server.name])
                rows.append(Row(name, "new" if fresh else "keep-alive", clients,
                                loads["drboard"], loads["floor"]))
    return rows


def measure_pushes(args: argparse.Namespace, servers: dict[str, Server], bodies: list[bytes]) -> list[Row]:
    rows = []
    left = {name: list(bodies) for name in servers}
    for fresh in (False, True):
        for clients in args.clients:
            print(f"push, {'new connections' if fresh else 'keep-alive'}, {clients} clients ...",
                  file=sys.stderr, flush=True)
            loads = {name: Load() for name in servers}
            for _ in range(args.rounds):
                for server in servers.values():  # interleaved: drboard, floor, validating floor
                    mine, left[server.name] = (left[server.name][:args.pushes],
                                               left[server.name][args.pushes:])
                    threads = min(clients, len(mine))
                    requests = [request_bytes("POST", PUSH_PATH, body=body, close=fresh) for body in mine]
                    job = Job(port=server.port, threads=threads, fresh=fresh,
                              start_at=time.monotonic() + 0.3, expect=201,
                              bodies=[requests[t::threads] for t in range(threads)])
                    window(server, job, min(threads, args.client_processes), loads[server.name])
            connections = "new" if fresh else "keep-alive"
            rows.append(Row("push", connections, clients, loads["drboard"], loads["floor"]))
            rows.append(Row("push (floor validates)", connections, clients, loads["drboard"],
                            loads["floor, validating"]))
    return rows


def warm_up(server: Server, requests: list[bytes]) -> None:
    """Requests answered before any window: a process's first ones build what it keeps."""
    run_job(Job(port=server.port, threads=1, fresh=False, start_at=0.0, expect=201,
                bodies=[requests]))


def stalled_connections(port: int, path: str) -> dict[str, float]:
    """Open connections that send nothing: is the server still answering, and does it let them go?"""
    stalled = [socket.create_connection(("127.0.0.1", port)) for _ in range(STALLED_CONNECTIONS)]
    opened = time.perf_counter()
    start = time.perf_counter()
    try:
        answered = fetch(port, request_bytes("GET", path, close=True))[0] == 200
    except OSError:
        answered = False
    answer_ms = (time.perf_counter() - start) * 1000
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
    parser.add_argument("--seconds", type=float, default=1.0,
                        help="each read window, per server (default 1)")
    parser.add_argument("--rounds", type=int, default=3,
                        help="interleaved windows per server and figure (default 3)")
    parser.add_argument("--pushes", type=int, default=120,
                        help="pushes per push window (default 120: each a new racer)")
    parser.add_argument("--client-processes", type=int, default=2,
                        help="processes the clients' threads are spread over (default 2)")
    parser.add_argument("--only", choices=["get", "push"], help="only the reads, or only the pushes")
    parser.add_argument("--seed", type=int, default=2019, help="random seed (default 2019)")
    parser.add_argument("--json", metavar="FILE", type=Path, help="also save the figures here")
    return parser.parse_args(argv)


def measure(args: argparse.Namespace, workdir: Path) -> tuple[list[Row], dict[str, float]]:
    seeded = workdir / "seeded.db"
    factory = RecordFactory(random.Random(args.seed))
    print(f"seeding {args.racers:,} racers ...", file=sys.stderr, flush=True)
    seed_board(seeded, args.racers, factory)
    pushes: dict[str, Any] = {}
    bodies: list[bytes] = []
    if args.only != "get":
        count = args.pushes * args.rounds * len(args.clients) * 2 + WARM_UP_PUSHES
        print(f"building {count:,} records and the storage work of each push ...",
              file=sys.stderr, flush=True)
        records = [factory.record(f"push-{index:06d}") for index in range(count)]
        bodies = [record.model_dump_json().encode() for record in records]
        pushes = storage_of_pushes(seeded, workdir, records)
    shutil.copyfile(seeded, workdir / "drboard.db")
    shutil.copyfile(seeded, workdir / "floor.db")
    drboard = start_drboard(workdir / "drboard.db", workdir)
    try:
        answers: dict[tuple[str, bool], Any] = {}
        etags: dict[str, str] = {}
        for path in set(READS.values()):
            status, headers, body = fetch(drboard.port, request_bytes("GET", path))
            answers[(path.split("?")[0], False)] = as_served(status, headers, body)
            etags[path] = dict(headers)[b"etag"].decode()
            held = fetch(drboard.port, request_bytes("GET", path, etag=etags[path]))
            answers[(path.split("?")[0], True)] = as_served(*held)
        (workdir / "answers.pickle").write_bytes(pickle.dumps(answers))
        (workdir / "pushes.pickle").write_bytes(pickle.dumps(pushes))
        floor = start_floor(workdir / "answers.pickle", workdir / "pushes.pickle" if pushes else None,
                            workdir / "floor.db" if pushes else None)
        try:
            servers = {"drboard": drboard, "floor": floor}
            rows = measure_reads(args, servers, etags) if args.only != "push" else []
            if args.only != "get":
                shutil.copyfile(seeded, workdir / "validating.db")
                validating = start_floor(workdir / "answers.pickle", workdir / "pushes.pickle",
                                         workdir / "validating.db", validate=True)
                try:
                    pushers = {"drboard": drboard, "floor": floor, validating.name: validating}
                    warm = [request_bytes("POST", PUSH_PATH, body=body) for body in bodies[:WARM_UP_PUSHES]]
                    for server in pushers.values():
                        warm_up(server, warm)
                    rows += measure_pushes(args, pushers, bodies[WARM_UP_PUSHES:])
                finally:
                    validating.stop()
        finally:
            floor.stop()
        print(f"{STALLED_CONNECTIONS} stalled connections ...", file=sys.stderr, flush=True)
        stalled = stalled_connections(drboard.port, READS["board JSON"])
    finally:
        drboard.stop()
    return rows, stalled


def table(rows: list[Row]) -> str:
    header = ("Request", "Connections", "Clients", "drboard req/s", "p50 ms", "p99 ms", "CPU µs/req",
              "errors", "floor req/s", "p50 ms", "p99 ms", "CPU µs/req", "req/s ratio", "CPU ratio")
    lines = [header]
    for row in rows:
        d, f = row.drboard, row.floor
        lines.append((row.request, row.connections, str(row.clients), f"{d.per_s:,.0f}",
                      f"{d.quantile_ms(50):.2f}", f"{d.quantile_ms(99):.2f}", f"{d.cpu_us:,.0f}",
                      str(d.errors + f.errors), f"{f.per_s:,.0f}", f"{f.quantile_ms(50):.2f}",
                      f"{f.quantile_ms(99):.2f}", f"{f.cpu_us:,.0f}", f"{row.ratio:.2f}",
                      f"{row.cpu_ratio:.2f}"))
    widths = [max(len(line[i]) for line in lines) for i in range(len(header))]
    shown = ["  ".join(cell.ljust(w) if i < 2 else cell.rjust(w) for i, (cell, w) in
                       enumerate(zip(line, widths, strict=True))) for line in lines]
    shown.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(shown)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="drboard-bench-serve-") as scratch:
        rows, stalled = measure(args, Path(scratch))
    load = os.getloadavg()
    print()
    print(f"drboard serve under load · {args.racers:,} racers · {args.rounds} interleaved windows "
          f"per server and figure ({args.seconds:g} s per read window, {args.pushes} pushes per push "
          f"window) · Python {sys.version.split()[0]} · {platform.platform()} · {os.cpu_count()} CPUs "
          f"· load average {load[0]:.1f}")
    print()
    print(table(rows))
    print()
    print("req/s ratio: drboard's requests per second over the floor's. CPU ratio: the floor's CPU "
          "per request over drboard's (each server's own process).")
    print(f"{stalled['stalled']:.0f} stalled connections (connected, nothing sent): "
          f"{'answered' if stalled['answered_meanwhile'] else 'NOT answered'} a pull meanwhile "
          f"in {stalled['answer_ms']:.1f} ms; {stalled['closed_by_server']:.0f} closed by the server, "
          f"the last after {stalled['last_closed_after_s']:.1f} s")
    if args.json:
        args.json.write_text(json.dumps({
            "config": {**vars(args), "json": str(args.json), "python": sys.version.split()[0],
                       "platform": platform.platform(), "cpus": os.cpu_count(), "load": load,
                       "started_at": datetime.now(UTC).isoformat(timespec="seconds")},
            "rows": [{"request": row.request, "connections": row.connections, "clients": row.clients,
                      **{name: {"per_s": load.per_s, "p50_ms": load.quantile_ms(50),
                                "p99_ms": load.quantile_ms(99), "cpu_us": load.cpu_us,
                                "errors": load.errors}
                         for name, load in (("drboard", row.drboard), ("floor", row.floor))},
                      "ratio": row.ratio, "cpu_ratio": row.cpu_ratio} for row in rows],
            "stalled": stalled,
        }, indent=2) + "\n")
        print(f"Figures saved to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
