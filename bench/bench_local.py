#!/usr/bin/env python3
"""Local performance figures of drboard on the embedded SQLite board, each beside its floor.

Not a test: it builds boards and a large run folder in a temporary folder, measures, and prints
one table of figures, each beside its floor (the same figure for the fastest honest program that
gives the same output), their ratio, and its target (PASS/FAIL). See bench/README.md.

    python bench/bench_local.py            # full run: 1,000 and 100,000 racers, 50 MB metrics
    python bench/bench_local.py --quick    # smoke run: 1,000 and 10,000 racers, 5 MB metrics
    python bench/bench_local.py --json figures.json

Standard library only, plus the drboard packages themselves and the `sqlite3` command-line
program (the floor of an export is its `.dump`).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import random
import resource
import shutil
import sqlite3
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import NamedTuple

from drboard_assembler import __version__ as ASSEMBLER_VERSION
from drboard_assembler.design import load_design
from drboard_assembler.record import (
    Design,
    EvaluationRun,
    Lap,
    RaceType,
    Record,
    SourceFile,
    SourceLayout,
    content_hash,
)
from drboard_cli.transfer import IMPORT_BATCH
from drboard_functions import ranking
from drboard_functions.models.requests import ImportedSubmission
from drboard_functions.service import LeaderboardService, scored_write
from drboard_functions.stores import rank_buckets
from drboard_functions.stores.sqlite import SqliteStore
from figures import Report, drboard_command, p50_p95, timed_ms

TRACK = "reInvent2019_track"  # "reInvent2019" resolves to it; its board id is the same
BOARD_ID = TRACK
MODEL = "bench-model"
#: Where the push floor writes its rows: a board id of its own, so the bench board is untouched.
FLOOR_BOARD = "bench-floor"
SQLITE3 = shutil.which("sqlite3") or "/usr/bin/sqlite3"

# ---- targets --------------------------------------------------------------------------------

PULL_P50_MAX_MS = 10.0
PULL_SCALING_MAX = 1.5
PUSH_P50_MAX_MS = 10.0
RANK_SCALING_MAX = 1.5
CLI_PULL_P50_MAX_MS = 500.0
ASSEMBLE_MAX_S = 2.0
ASSEMBLE_PEAK_MAX_X = 10.0
EXPORT_VS_DUMP_MAX_X = 3.0
IMPORT_VS_EXECUTEMANY_MAX_X = 3.0

# ---- the model's files (also used to build in-memory records) ---------------------------------

METADATA = {
    "action_space": [
        {"steering_angle": angle, "speed": speed, "index": index}
        for index, (angle, speed) in enumerate(
            (a, s) for a in (-30, -20, -10, 0, 10, 20, 30) for s in (1.75, 3.5))
    ],
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "training_algorithm": "clipped_ppo",
    "action_space_type": "discrete",
    "version": "4",
}
HYPERPARAMETERS = {
    "batch_size": 64, "beta_entropy": 0.01, "discount_factor": 0.99, "e_greedy_value": 0.05,
    "epsilon_steps": 10000, "exploration_type": "categorical", "loss_type": "huber",
    "lr": 0.0003, "num_episodes_between_training": 20, "num_epochs": 5, "stack_size": 1,
    "term_cond_avg_score": 100000.0, "term_cond_max_episodes": 5000,
}


# ---- building records cheaply -----------------------------------------------------------------


class RecordFactory:
    """Distinct, valid Records that differ in racer, laps and design: each racer trained with
    hyperparameters of their own (learning rate, batch size, epochs, discount, entropy), as the
    racers of a real board do, so that nothing a board does once per distinct design is done
    once for the whole board.

    The design is parsed once and varied per record; each record is one EvaluationRun.from_laps
    (validated) and the record put together from validated parts, with its submission id computed
    from its content (``content_hash``), without validating the whole record again: the first
    record made is checked to validate as every record does (today's checks and its content hash
    included).
    Records carry no training summary, which keeps them (and the seeded database) small; pull
    and push never read it.
    """

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.design = load_design(json.dumps(METADATA).encode(), "model/model_metadata.json",
                                  json.dumps(HYPERPARAMETERS).encode(), "ip/hyperparameters.json")
        self.provenance = [SourceFile(role="evaluation_metrics",
                                      path="metrics/EvaluationMetrics-20220709200242.json",
                                      sha256="0" * 64, bytes=1234)]
        self.checked = False

    def laps(self) -> list[Lap]:
        """Nine racers in ten complete three laps (best lap 8-30 s); the others go off track."""
        rng = self.rng
        if rng.random() < 0.9:
            base = rng.randint(8_000, 30_000)
            return [Lap(trial=k + 1, time_ms=base + rng.randint(0, 2_000), completion_pct=100,
                        status="Lap complete") for k in range(3)]
        return [Lap(trial=1, time_ms=rng.randint(1_000, 20_000),
                    completion_pct=rng.randint(1, 99), status="Off track")]

    def own_design(self) -> Design:
        """The design with a racer's own hyperparameters (valid values, chosen at random)."""
        rng, base = self.rng, self.design
        assert base.hyperparameters is not None
        own = base.hyperparameters.model_copy(update={
            "lr": round(10 ** rng.uniform(-5, -3), 8), "batch_size": rng.choice((32, 64, 128, 256, 512)),
            "num_epochs": rng.randint(3, 10), "discount_factor": round(rng.uniform(0.9, 0.999), 4),
            "beta_entropy": round(rng.uniform(0.001, 0.05), 4)})
        return base.model_copy(update={"hyperparameters": own})

    def record(self, racer: str, laps: list[Lap] | None = None) -> Record:
        run = EvaluationRun.from_laps("metrics/EvaluationMetrics-20220709200242.json",
                                      laps if laps is not None else self.laps())
        draft = Record.model_construct(
            submission_id="0" * 64, track=TRACK, racer=racer, model_name=MODEL,
            race_type=RaceType.TIME_TRIAL, source_layout=SourceLayout.DRFC,
            assembler_version=ASSEMBLER_VERSION, evaluations=[run], design=self.own_design(),
            training=None, provenance=self.provenance)
        record = draft.model_copy(update={"submission_id": content_hash(draft)})
        if not self.checked:
            assert Record.model_validate_json(record.model_dump_json()) == record
            self.checked = True
        return record


SEED_BATCH = IMPORT_BATCH  # as `drboard import` writes


def seed_board(path: Path, racers: int, factory: RecordFactory) -> float:
    """A board of ``racers`` racers in a new SQLite file; returns the seconds it took.

    The first racer is pushed (which creates the board); the others are written as `drboard
    import` writes an export (LeaderboardService.bulk_import, SEED_BATCH a transaction): each
    racer's submission with its record, their entry, the rank counts, the runs' index, the
    claims and the audit trail, all as pushes leave them.
    """
    start = time.perf_counter()
    store = SqliteStore(path)
    service = LeaderboardService(store)
    service.push(factory.record("seed-000000"))
    board = store.get_board(BOARD_ID)
    assert board is not None
    bulk = service.bulk_import(board.board)
    bulk.open()
    base = datetime(2024, 1, 1, tzinfo=UTC)
    for first in range(1, racers, SEED_BATCH):
        bulk.load([bulk.prepare(ImportedSubmission.model_construct(
            submitted_at=base + timedelta(seconds=n), record=factory.record(f"seed-{n:06d}")))
            for n in range(first, min(racers, first + SEED_BATCH))])
    store.close()
    elapsed = time.perf_counter() - start
    with sqlite3.connect(path) as check:
        check.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    stored = SqliteStore(path)
    participants = LeaderboardService(stored).board_page(BOARD_ID, limit=1).board.participants
    stored.close()
    assert participants == racers, (participants, racers)
    return elapsed


# ---- timing programs ----------------------------------------------------------------------------


class Timing(NamedTuple):
    wall: float  # seconds
    cpu: float  # seconds of CPU (user + system), the program's own


def timed_program(argv: list[str], stdout: Path | None = None,
                  env: dict[str, str] | None = None) -> Timing:
    """Run a program to its end; its wall time and the CPU time it used."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    with (stdout.open("wb") if stdout else open(os.devnull, "wb")) as out:
        done = subprocess.run(argv, stdout=out, stderr=subprocess.PIPE, env=env, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({done.returncode}):\n"
                         + done.stderr.decode(errors="replace"))
    return Timing(wall, after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)


def timed_child(code: str, *args: str) -> Timing:
    """A Python child that times its own work and prints it as JSON ({"wall", "cpu"}). What
    earlier programs wrote is flushed to the disk first: none is timed while the system still
    writes out another's files (an import and its floor write some 600 MiB each)."""
    os.sync()
    done = subprocess.run([sys.executable, "-c", code, *args], capture_output=True, check=False,
                          text=True)
    if done.returncode != 0:
        raise SystemExit(f"a timed child failed:\n{done.stderr}")
    answer = json.loads(done.stdout.strip().splitlines()[-1])
    return Timing(answer["wall"], answer["cpu"])


def medians(timings: list[Timing]) -> Timing:
    return Timing(statistics.median(t.wall for t in timings), statistics.median(t.cpu for t in timings))


def interleaved(programs: dict[str, Callable[[], Timing]], runs: int) -> dict[str, Timing]:
    """Each program ``runs`` times, taking turns, so that the machine's drift and other load fall
    on each alike: the median wall and CPU times of each."""
    timings: dict[str, list[Timing]] = {name: [] for name in programs}
    for _ in range(runs):
        for name, program in programs.items():
            timings[name].append(program())
    return {name: medians(found) for name, found in timings.items()}


#: The floor of writing a board's rows: a plain executemany of every row of every table of the
#: board file ``argv[1]`` (read first, untimed) into the empty schema of a new file ``argv[2]``
#: (made by SqliteStore: the same tables, indexes and settings), in one transaction.
EXECUTEMANY_CHILD = textwrap.dedent("""
    import json, sqlite3, sys, time
    from drboard_functions.stores.sqlite import SqliteStore

    with sqlite3.connect(sys.argv[1]) as source:
        tables = [name for (name,) in source.execute(
            "SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")]
        rows = {table: source.execute(f"SELECT * FROM {table}").fetchall() for table in tables}
    SqliteStore(sys.argv[2]).close()
    db = sqlite3.connect(sys.argv[2], isolation_level=None)
    db.execute("PRAGMA synchronous=NORMAL")
    start, cpu = time.perf_counter(), time.process_time()
    db.execute("BEGIN IMMEDIATE")
    for table, found in rows.items():
        if found:
            db.executemany(f"INSERT INTO {table} VALUES ({','.join('?' * len(found[0]))})", found)
    db.execute("COMMIT")
    db.close()
    print(json.dumps({"wall": time.perf_counter() - start, "cpu": time.process_time() - cpu,
                      "rows": sum(map(len, rows.values()))}))
""")

#: `drboard import` of the export ``argv[1]`` into a new board file ``argv[2]``, as the command
#: runs it on the embedded board (every line checked and prepared, the submissions written in
#: bulk as they are, in one transaction), timed from the start of the import (the interpreter's
#: start and imports left out, as for its floor). Its CPU time includes the worker processes
#: that check a big file's lines.
IMPORT_CHILD = textwrap.dedent("""
    import json, resource, sys, time
    from pathlib import Path
    from drboard_cli import transfer
    from drboard_functions.services import sqlite_service

    def cpu_s():
        own, workers = (resource.getrusage(who) for who in (resource.RUSAGE_SELF,
                                                             resource.RUSAGE_CHILDREN))
        return own.ru_utime + own.ru_stime + workers.ru_utime + workers.ru_stime

    service = sqlite_service(Path(sys.argv[2]))
    start, cpu = time.perf_counter(), cpu_s()
    with open(sys.argv[1], "rb") as handle:
        summary = transfer.load_export(service, sys.argv[1], handle, None)
    wall, cpu = time.perf_counter() - start, cpu_s() - cpu
    print(json.dumps({"wall": wall, "cpu": cpu, "created": summary.created}))
""")


def fresh(path: Path) -> Path:
    """``path`` with no board file (nor its WAL) left from an earlier run."""
    for suffix in ("", "-wal", "-shm"):
        Path(f"{path}{suffix}").unlink(missing_ok=True)
    return path


def executemany_floor(source: Path, workdir: Path) -> Timing:
    return timed_child(EXECUTEMANY_CHILD, str(source), str(fresh(workdir / "floor.db")))


# ---- 1 and 2: push and pull in-process ----------------------------------------------------------


def bench_pull(report: Report, path: Path, size: int, label: str, reps: int) -> float:
    """board_page(limit=100) against its floor: the same 100 entries read as they are stored,
    with nothing parsed nor built (the query itself)."""
    store = SqliteStore(path)
    service = LeaderboardService(store)
    bare = sqlite3.connect(path)
    query = ("SELECT entry FROM entries WHERE board_id = ? ORDER BY rank_key LIMIT 100", (BOARD_ID,))
    for _ in range(10):  # warm: page cache, statement cache, imports
        service.board_page(BOARD_ID, limit=100)
        bare.execute(*query).fetchall()
    page = service.board_page(BOARD_ID, limit=100)
    assert len(page.entries) == 100 and page.board.participants == size
    samples, floors, tops = [], [], []
    for _ in range(reps):  # in turns: drift falls on each alike
        samples.append(timed_ms(lambda: service.board_page(BOARD_ID, limit=100)))
        floors.append(timed_ms(lambda: bare.execute(*query).fetchall()))
        tops.append(timed_ms(lambda: store.top(BOARD_ID, 100)))
    (p50, p95), (floor50, floor95) = p50_p95(samples), p50_p95(floors)
    floor = "SELECT of the same 100 entries' stored JSON (sqlite3 module, nothing parsed)"
    report.add(f"pull top-100 p50 @ {label}", p50, "ms", limit=PULL_P50_MAX_MS, floor=floor50,
               floor_name=floor)
    report.add(f"pull top-100 p95 @ {label}", p95, "ms", floor=floor95, floor_name=floor)
    # Where a page's time goes: the store's read (SQL + Entry parsing) versus the rest.
    report.add(f"  of which store.top(100) p50 @ {label}", p50_p95(tops)[0], "ms", floor=floor50,
               floor_name=floor)
    bare.close()
    store.close()
    return p50


def bench_push(report: Report, path: Path, label: str, records: list[Record],
               warmup: int) -> None:
    """push() of a new racer against its floor: one transaction inserting the rows a push must
    write — the submission (its record's JSON in it) and the racer's entry — built beforehand,
    on the same board file (under a board id of its own)."""
    store = SqliteStore(path)
    service = LeaderboardService(store)
    rules_board = store.get_board(BOARD_ID)
    assert rules_board is not None
    floor_board = rules_board.board.model_copy(update={"board_id": FLOOR_BOARD})
    rows = []
    for record in records:  # built before timing: the floor only writes
        submission, entry = scored_write(record, floor_board, datetime.now(UTC))
        rows.append(((FLOOR_BOARD, submission.submission_id, submission.racer_key,
                      ranking.timestamp(submission.submitted_at), submission.model_dump_json(),
                      record.model_dump_json()),
                     (FLOOR_BOARD, entry.racer_key, entry.score_key, entry.rank_key,
                      entry.model_dump_json())))
    bare = sqlite3.connect(path, isolation_level=None)
    bare.execute("PRAGMA synchronous=NORMAL")

    def floor_write(submission_row: tuple[object, ...], entry_row: tuple[object, ...]) -> None:
        bare.execute("BEGIN IMMEDIATE")
        bare.execute("INSERT INTO submissions VALUES (?, ?, ?, ?, ?, ?)", submission_row)
        bare.execute("INSERT OR REPLACE INTO entries VALUES (?, ?, ?, ?, ?)", entry_row)
        bare.execute("COMMIT")

    for record, (submission_row, entry_row) in zip(records[:warmup], rows, strict=False):
        service.push(record)
        floor_write(submission_row, entry_row)
    samples, floors, ranks = [], [], []
    for record, (submission_row, entry_row) in zip(records[warmup:], rows[warmup:], strict=True):
        start = time.perf_counter()
        receipt = service.push(record)
        samples.append((time.perf_counter() - start) * 1000)
        floors.append(timed_ms(lambda s=submission_row, e=entry_row: floor_write(s, e)))
        assert receipt.status == "created"
        ranks.append(receipt.rank / receipt.participants)
    (p50, p95), (floor50, floor95) = p50_p95(samples), p50_p95(floors)
    floor = ("one transaction inserting the push's submission (with its record) and entry rows, "
             "built beforehand")
    report.add(f"push new racer p50 @ {label}", p50, "ms", limit=PUSH_P50_MAX_MS, floor=floor50,
               floor_name=floor,
               note=f"{len(samples)} pushes after {warmup} warm-up ones; lap times drawn like "
                    f"the seeded racers' (median rank at {statistics.median(ranks):.0%} of "
                    "the board)")
    report.add(f"push new racer p95 @ {label}", p95, "ms", floor=floor95, floor_name=floor)
    # The one query in push whose cost grows with the board: the rank count.
    keys = [ranking.score_key(ranking.score_record(r, rules_board.board.rules))
            for r in records[warmup:]]
    counts = [timed_ms(lambda k=k: store.count_better(BOARD_ID, k)) for k in keys]
    points = [timed_ms(lambda: point_read(bare)) for _ in keys]
    report.add(f"  of which count_better p50 @ {label}", p50_p95(counts)[0], "ms",
               floor=p50_p95(points)[0], floor_name=POINT_READ)
    bare.close()
    store.close()


POINT_READ = "one entry read by its primary key (sqlite3 module)"


def point_read(db: sqlite3.Connection) -> object:
    return db.execute("SELECT entry FROM entries WHERE board_id = ? AND racer_key = ?",
                      (BOARD_ID, "seed-000000")).fetchone()


def bench_rank(report: Report, boards: dict[str, Path], reps: int) -> None:
    """Ranks on each board (label -> file): a mid-board push's (a 19 s lap; laps are drawn from
    8-30 s) and the last racer's, which a public read of them (``racer``) counts. Rows read are
    those of the counts a rank adds up (the floor: one row, a rank stored whole); for
    comparison, the entries the count read before them. A rank's time is held to one entry
    read by its primary key; a racer view's to the same reads as bare SQL. Timed alternately
    on the boards, so that drift (other load on the machine) falls on each."""
    middle = _lap_record("bench-rank-middle", [19_000, 19_500, 20_000], 100)
    last = _lap_record("bench-rank-last", [9_000], 0.5)  # below every seeded racer
    stores = {label: SqliteStore(path) for label, path in boards.items()}
    bares = {label: sqlite3.connect(path) for label, path in boards.items()}
    names = ("mid-board push's rank", "last racer's rank", "racer view of the last racer")
    calls: dict[str, list[Callable[[], object]]] = {name: [] for name in names}
    floors: dict[str, list[Callable[[], object]]] = {name: [] for name in names}
    for label, store in stores.items():
        service = LeaderboardService(store)
        board = store.get_board(BOARD_ID)
        assert board is not None
        mid = service.push(middle)
        service.push(last)
        view = service.racer(BOARD_ID, last.racer)
        assert view.entry.rank == view.board.participants
        bare = bares[label]
        for name, record, rank in ((names[0], middle, mid.rank), (names[1], last, view.entry.rank)):
            key = ranking.score_key(ranking.score_record(record, board.board.rules))
            rows, entries = _rows_read(boards[label], key)
            report.add(f"rows read by the {name} (rank {rank:,}) @ {label}", rows, "rows",
                       floor=1, floor_name="one row read (a rank stored whole)",
                       note=f"counts summed; the count before them read {entries:,} entries")
            calls[name].append(lambda store=store, key=key: store.count_better(BOARD_ID, key))
            floors[name].append(lambda bare=bare: point_read(bare))
        calls[names[2]].append(lambda service=service: service.racer(BOARD_ID, last.racer))
        last_key = ranking.score_key(ranking.score_record(last, board.board.rules))
        floors[names[2]].append(lambda bare=bare, key=last_key: _racer_reads(
            bare, "bench-rank-last", last.submission_id, key))
    for name in names:
        batch = 1 if name == names[2] else 100  # a rank takes microseconds
        samples: list[list[float]] = [[] for _ in boards]
        floored: list[list[float]] = [[] for _ in boards]
        for _ in range(reps):
            for index in range(len(boards)):
                samples[index].append(_timed_batch(calls[name][index], batch))
                floored[index].append(_timed_batch(floors[name][index], batch))
        p50s = [p50_p95(timings)[0] for timings in samples]
        for label, p50, floor in zip(boards, p50s, floored, strict=True):
            report.add(f"{name} p50 @ {label}", p50, "ms", floor=p50_p95(floor)[0],
                       floor_name=POINT_READ if name != names[2] else
                       "the same reads as bare SQL: board, entry, record, history, leader, counts")
        small, large = boards
        report.add(f"{name} p50 ratio {large} / {small}", p50s[1] / p50s[0], "x",
                   limit=RANK_SCALING_MAX, floor=1.0, floor_name="the same time at both sizes")
    for store in stores.values():
        store.close()
    for bare in bares.values():
        bare.close()


def _racer_reads(db: sqlite3.Connection, racer_key: str, submission_id: str, score_key: str) -> None:
    """What a racer view reads, as bare SQL: the board, the entry, its record, the racer's
    history, the leader and the counts of the rank."""
    db.execute("SELECT board FROM boards WHERE board_id = ?", (BOARD_ID,)).fetchone()
    db.execute("SELECT entry FROM entries WHERE board_id = ? AND racer_key = ?",
               (BOARD_ID, racer_key)).fetchone()
    db.execute("SELECT record FROM submissions WHERE board_id = ? AND submission_id = ?",
               (BOARD_ID, submission_id)).fetchone()
    db.execute("SELECT submission FROM submissions WHERE racer_key = ? ORDER BY submitted_at "
               "LIMIT 101", (racer_key,)).fetchall()
    db.execute("SELECT entry FROM entries WHERE board_id = ? ORDER BY rank_key LIMIT 1",
               (BOARD_ID,)).fetchone()
    for node, child in rank_buckets.path(score_key):
        db.execute("SELECT SUM(entries) FROM rank_counts WHERE board_id = ? AND node = ? AND "
                   "child < ?", (BOARD_ID, node, child)).fetchone()


def _timed_batch(call: Callable[[], object], batch: int) -> float:
    """Milliseconds per call, over ``batch`` calls."""
    def calls() -> None:
        for _ in range(batch):
            call()
    return timed_ms(calls) / batch


def _lap_record(racer: str, times: list[int], completion: float) -> Record:
    laps = [Lap(trial=k + 1, time_ms=ms, completion_pct=completion,
                status="Lap complete" if completion >= 100 else "Off track")
            for k, ms in enumerate(times)]
    return RecordFactory(random.Random(0)).record(racer, laps)


def _rows_read(path: Path, score_key: str) -> tuple[int, int]:
    """The count rows a rank of ``score_key`` adds up, and the entries counted before them."""
    with sqlite3.connect(path) as db:
        rows = sum(db.execute("SELECT COUNT(*) FROM rank_counts WHERE board_id = ? AND node = ? "
                              "AND child < ?", (BOARD_ID, node, child)).fetchone()[0]
                   for node, child in rank_buckets.path(score_key))
        entries = db.execute("SELECT COUNT(*) FROM entries WHERE board_id = ? AND rank_key < ?",
                             (BOARD_ID, score_key)).fetchone()[0]
    return rows, entries


# ---- 3: the whole `drboard pull` command --------------------------------------------------------


#: The CLI run in-process, where no `drboard` script is installed.
CLI_IN_PYTHON = [sys.executable, "-c", "from drboard_cli.main import cli; cli()"]

#: The floor of a `drboard pull`: a program that starts Python, imports click and rich, reads the
#: same 100 entries from the board file, and prints the same bytes (``argv[2]``, what drboard
#: printed) — all a pull does, with none of its parsing, ranking or rendering.
PULL_FLOOR = textwrap.dedent("""
    import sqlite3, sys
    import click, rich
    db = sqlite3.connect(sys.argv[1])
    db.execute("SELECT entry FROM entries WHERE board_id = ? ORDER BY rank_key LIMIT 100",
               (sys.argv[3],)).fetchall()
    with open(sys.argv[2], "rb") as printed:
        sys.stdout.buffer.write(printed.read())
""")


def bench_cli(report: Report, path: Path, workdir: Path, label: str, runs: int,
              command: list[str]) -> None:
    env = dict(os.environ, DRBOARD_DB=str(path), COLUMNS="160")
    env.pop("NO_COLOR", None)
    for fmt in ("json", "table"):
        argv = [*command, "pull", "--board", BOARD_ID, "--top", "100", "--format", fmt]
        printed = workdir / f"pull.{fmt}"
        timed_program(argv, printed, env)  # warm: the OS caches the files and .pyc
        if fmt == "json":
            assert len(json.loads(printed.read_bytes())["entries"]) == 100
        floor = [sys.executable, "-c", PULL_FLOOR, str(path), str(printed), BOARD_ID]
        timed_program(floor, None, env)
        times = interleaved({"pull": lambda argv=argv: timed_program(argv, None, env),
                             "floor": lambda floor=floor: timed_program(floor, None, env)}, runs)
        report.add(f"`drboard pull --top 100 --format {fmt}` p50 @ {label}",
                   times["pull"].wall * 1000, "ms", limit=CLI_PULL_P50_MAX_MS,
                   floor=times["floor"].wall * 1000,
                   floor_name="python + click + rich + sqlite3 reading the same 100 entries and "
                              "printing the same bytes",
                   note=f"CPU {times['pull'].cpu * 1000:,.0f} ms against "
                        f"{times['floor'].cpu * 1000:,.0f} ms")
    # The floor under every command: starting Python and importing the CLI and the service.
    imports = [sys.executable, "-c",
               "import drboard_cli.main, drboard_functions.service, drboard_functions.stores.sqlite"]
    bare = [sys.executable, "-c", "import click, rich"]
    times = interleaved({"imports": lambda: timed_program(imports, None, env),
                         "bare": lambda: timed_program(bare, None, env)}, runs)
    report.add("  of which python start + imports p50", times["imports"].wall * 1000, "ms",
               floor=times["bare"].wall * 1000, floor_name='python -c "import click, rich"')


# ---- 4: assembling a run with a large training metrics file -------------------------------------

TRAINING_TEMPLATE = (
    '{{"reward_score": {reward}, "metric_time": {end}, "start_time": {start}, '
    '"elapsed_time_in_milliseconds": {elapsed}, "episode": {episode}, "trial": {trial}, '
    '"phase": "{phase}", "completion_percentage": {completion}, '
    '"episode_status": "{status}"}}'
)


def write_run_folder(root: Path, target_bytes: int, rng: random.Random) -> tuple[int, int]:
    """A DeepRacer-for-Cloud run folder whose metrics/TrainingMetrics.json is ~target_bytes.

    Returns (the training file's size, the number of training-phase episodes in it)."""
    (root / "model").mkdir(parents=True)
    (root / "ip").mkdir()
    (root / "metrics").mkdir()
    (root / "model" / "model_metadata.json").write_text(json.dumps(METADATA, indent=2))
    (root / "ip" / "hyperparameters.json").write_text(json.dumps(HYPERPARAMETERS, indent=2))

    training = root / "metrics" / "TrainingMetrics.json"
    clock = 27_746
    episode = 0
    training_episodes = 0
    written = 0
    with training.open("w", encoding="utf-8") as handle:
        head = '{"metrics": ['
        handle.write(head)
        written += len(head)
        chunk: list[str] = []
        tail = '], "version": 2.0, "best_model_metric": "progress"}'
        while written + len(tail) < target_bytes:
            episode += 1
            # DRfC alternates 20 training episodes with 6 evaluation episodes.
            phase = "evaluation" if episode % 26 >= 20 else "training"
            training_episodes += phase == "training"
            completion = 100 if rng.random() < 0.1 else rng.randint(1, 99)
            elapsed = rng.randint(300, 15_000)
            text = TRAINING_TEMPLATE.format(
                reward=rng.randint(0, 300) if completion < 100 else rng.randint(300, 2_000),
                end=clock + elapsed, start=clock, elapsed=elapsed, episode=episode,
                trial=(episode - 1) % 20 + 1, phase=phase, completion=completion,
                status="Lap complete" if completion == 100 else "Off track",
            )
            clock += elapsed + rng.randint(200, 800)
            piece = text if episode == 1 else ", " + text
            chunk.append(piece)
            written += len(piece)
            if len(chunk) >= 10_000:
                handle.write("".join(chunk))
                chunk.clear()
        handle.write("".join(chunk))
        handle.write(tail)

    laps = []
    start = 7_043
    for trial in (1, 2, 3):
        elapsed = 13_500 + rng.randint(0, 1_000)
        laps.append({
            "completion_percentage": 100, "metric_time": start + elapsed, "start_time": start,
            "elapsed_time_in_milliseconds": elapsed,
            "episode_status": "Lap complete" if trial == 3 else "In progress",
            "crash_count": 0, "immobilized_count": 0, "off_track_count": 0,
            "reversed_count": 0, "reset_count": 0, "trial": trial,
        })
        start += elapsed
    (root / "metrics" / "EvaluationMetrics-20220709200242.json").write_text(
        json.dumps({"metrics": laps}))
    return training.stat().st_size, training_episodes


#: Measures RSS in a fresh interpreter: after its imports, and at its peak after ``work``.
MEMORY = textwrap.dedent("""
    import gc, json, resource, sys, time

    def rss_kib():
        try:
            with open("/proc/self/status") as status:
                for line in status:
                    if line.startswith("VmRSS:"):
                        return int(line.split()[1])
        except OSError:
            pass
        return peak_kib()

    def peak_kib():
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return peak // 1024 if sys.platform == "darwin" else peak

    def measured(work):
        gc.collect()
        before = rss_kib()
        start, cpu = time.perf_counter(), time.process_time()
        answer = work()
        seconds, cpu = time.perf_counter() - start, time.process_time() - cpu
        return {"seconds": seconds, "cpu": cpu, "rss_before_kib": before,
                "peak_after_kib": peak_kib()} | answer
""")

# Assembles the run folder argv[1] (its race type given, as its files do not say it).
ASSEMBLE_CHILD = MEMORY + textwrap.dedent("""
    from pathlib import Path
    from drboard_assembler import Overrides, assemble

    def work():
        record = assemble(Path(sys.argv[1]), Overrides(track="reInvent2019", racer="Bench",
                                                       race_type="time_trial"))
        return {"episodes": record.training.episodes, "best_lap_ms": record.best_run.best_lap_ms,
                "record_bytes": len(record.model_dump_json())}

    print(json.dumps(measured(work)))
""")

# The floor of assembling: reading and parsing the same training metrics file with the
# standard library's json, and nothing else.
PARSE_CHILD = MEMORY + textwrap.dedent("""
    from pathlib import Path

    def work():
        metrics = json.loads(Path(sys.argv[1]).read_bytes())["metrics"]
        return {"episodes": sum(m["phase"] == "training" for m in metrics)}

    print(json.dumps(measured(work)))
""")


def _measured(code: str, path: Path) -> dict[str, float]:
    done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True,
                          check=False, text=True)
    if done.returncode != 0:
        raise SystemExit(f"measuring {path} failed:\n{done.stderr}")
    answer: dict[str, float] = json.loads(done.stdout)
    return answer


def bench_assemble(report: Report, workdir: Path, megabytes: float, runs: int,
                   rng: random.Random) -> None:
    root = workdir / "big-run"
    start = time.perf_counter()
    size, episodes = write_run_folder(root, int(megabytes * 1_000_000), rng)
    print(f"  wrote {size / 1e6:.1f} MB TrainingMetrics.json ({episodes:,} training episodes) "
          f"in {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)
    training = root / "metrics" / "TrainingMetrics.json"
    results: list[dict[str, float]] = []
    floors: list[dict[str, float]] = []
    for _ in range(runs):  # in turns: drift falls on each alike
        results.append(_measured(ASSEMBLE_CHILD, root))
        floors.append(_measured(PARSE_CHILD, training))
    for result in results + floors:
        assert result["episodes"] == episodes, (result["episodes"], episodes)
    label = f"{size / 1e6:.0f} MB"
    floor = "json.loads of the same training metrics file, in a fresh process"
    seconds = statistics.median(r["seconds"] for r in results)
    report.add(f"assemble {label} run: wall time (median of {runs})", seconds, "s",
               limit=ASSEMBLE_MAX_S, floor=statistics.median(f["seconds"] for f in floors),
               floor_name=floor,
               note=f"CPU {statistics.median(r['cpu'] for r in results):.2f} s against "
                    f"{statistics.median(f['cpu'] for f in floors):.2f} s")
    increase = max(r["peak_after_kib"] - r["rss_before_kib"] for r in results) * 1024
    parsed = max(f["peak_after_kib"] - f["rss_before_kib"] for f in floors) * 1024
    report.add(f"assemble {label} run: peak RSS increase", increase / 2**20, "MiB",
               floor=parsed / 2**20, floor_name=floor)
    report.add(f"assemble {label} run: peak RSS increase / file size", increase / size, "x",
               limit=ASSEMBLE_PEAK_MAX_X, floor=parsed / size, floor_name=floor)
    report.config["assemble"] = {"training_file_bytes": size, "training_episodes": episodes,
                                 "runs": results, "floors": floors}


# ---- 5: export and import of a whole board ------------------------------------------------------


def bench_export(report: Report, path: Path, workdir: Path, label: str, runs: int,
                 command: list[str]) -> Path:
    """`drboard export` of the board to a file, against `sqlite3 BOARD .dump` of the same file
    (every row of every table, as SQL text): each a whole program, in turns. Returns the export."""
    exported, dumped = workdir / "export.jsonl", workdir / "dump.sql"
    export = [*command, "--db", str(path), "export", BOARD_ID, "-o", str(exported)]
    dump = [SQLITE3, str(path), ".dump"]
    times = interleaved({"export": lambda: timed_program(export),
                         "dump": lambda: timed_program(dump, dumped)}, runs)
    lines = sum(1 for _ in exported.open("rb"))
    report.add(f"`drboard export` {label}", times["export"].wall, "s",
               floor=times["dump"].wall, floor_name=f"`sqlite3 BOARD .dump` ({SQLITE3}) of the "
               f"same file, to a file ({dumped.stat().st_size / 2**20:,.0f} MiB)",
               ratio_limit=EXPORT_VS_DUMP_MAX_X,
               note=f"{lines:,} lines, {exported.stat().st_size / 2**20:,.0f} MiB; median of "
                    f"{runs} runs in turns")
    report.add(f"`drboard export` {label}: CPU time", times["export"].cpu, "s",
               floor=times["dump"].cpu, floor_name="the same dump's CPU time")
    dumped.unlink()
    return exported


def bench_import(report: Report, exported: Path, workdir: Path, label: str, runs: int) -> None:
    """`drboard import` of that export into an empty board file, against a plain executemany of
    every row the import ends with into an empty schema (the floor child): in turns."""
    target = workdir / "imported.db"

    def load() -> Timing:
        return timed_child(IMPORT_CHILD, str(exported), str(fresh(target)))

    first = load()  # its rows are the floor's
    times = interleaved({"import": load, "floor": lambda: executemany_floor(target, workdir)},
                        runs)
    with sqlite3.connect(target) as db:
        rows = sum(db.execute(f"SELECT COUNT(*) FROM {table}").fetchone()[0]
                   for (table,) in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'"))
    report.add(f"`drboard import` {label} into an empty board", times["import"].wall, "s",
               floor=times["floor"].wall,
               floor_name=f"a plain executemany of the same {rows:,} rows into an empty schema, "
                          "one transaction",
               ratio_limit=IMPORT_VS_EXECUTEMANY_MAX_X,
               note=f"median of {runs} runs in turns (first run {first.wall:.1f} s); the import "
                    "checks every record (schema, bounds, content hash, size) on every core "
                    "while it writes them, in one transaction committed once all are checked")
    report.add(f"`drboard import` {label}: CPU time", times["import"].cpu, "s",
               floor=times["floor"].cpu, floor_name="the same executemany's CPU time",
               note="the import's own and its workers'")


# ---- main ---------------------------------------------------------------------------------------


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true",
                        help="smoke run: boards of 1,000 and 10,000 racers, a 5 MB metrics file, "
                             "fewer repetitions")
    parser.add_argument("--json", metavar="FILE", type=Path, help="also save the figures here")
    parser.add_argument("--sizes", metavar="N", type=int, nargs=2,
                        help="the small and large board sizes (default 1000 100000; "
                             "--quick: 1000 10000)")
    parser.add_argument("--metrics-mb", type=float,
                        help="size of the training metrics file in MB (default 50; --quick: 5)")
    parser.add_argument("--pull-reps", type=int, help="board_page calls per size (default 300)")
    parser.add_argument("--pushes", type=int, help="timed pushes per size (default 200)")
    parser.add_argument("--cli-runs", type=int, help="runs of each drboard command (default 15)")
    parser.add_argument("--assemble-runs", type=int,
                        help="fresh subprocesses assembling the big run (default 3)")
    parser.add_argument("--transfer-runs", type=int,
                        help="runs of the export and the import, each in turn with its floor "
                             "(default 3; --quick: 1)")
    parser.add_argument("--drboard", metavar="PATH",
                        help="the drboard executable (default: the one beside this Python)")
    parser.add_argument("--workdir", type=Path,
                        help="build the boards and run folder here and keep them "
                             "(default: a temporary folder, removed afterwards)")
    parser.add_argument("--seed", type=int, default=2019, help="random seed (default 2019)")
    parser.add_argument("--skip", choices=["push", "pull", "cli", "assemble", "export", "import"],
                        action="append", default=[], help="skip a part (repeatable)")
    args = parser.parse_args(argv)
    quick = args.quick
    args.sizes = args.sizes or ([1_000, 10_000] if quick else [1_000, 100_000])
    args.metrics_mb = args.metrics_mb or (5.0 if quick else 50.0)
    args.pull_reps = args.pull_reps or (100 if quick else 300)
    args.pushes = args.pushes or (50 if quick else 200)
    args.cli_runs = args.cli_runs or (5 if quick else 15)
    args.assemble_runs = args.assemble_runs or (1 if quick else 3)
    args.transfer_runs = args.transfer_runs or (1 if quick else 3)
    if "export" in args.skip:
        args.skip.append("import")  # it imports the export
    return args


def label_of(size: int) -> str:
    return f"{size:,} racers"


def run(args: argparse.Namespace, workdir: Path) -> Report:
    report = Report(config={
        "sizes": args.sizes, "metrics_mb": args.metrics_mb, "pull_reps": args.pull_reps,
        "pushes": args.pushes, "cli_runs": args.cli_runs, "assemble_runs": args.assemble_runs,
        "transfer_runs": args.transfer_runs, "quick": args.quick,
        "python": sys.version.split()[0], "sqlite": sqlite3.sqlite_version,
        "platform": platform.platform(), "cpus": os.cpu_count(),
        "load_average": os.getloadavg() if hasattr(os, "getloadavg") else None,
        "started_at": datetime.now(UTC).isoformat(timespec="seconds"),
    })
    rng = random.Random(args.seed)
    factory = RecordFactory(rng)
    small, large = args.sizes
    command = drboard_command(args.drboard, CLI_IN_PYTHON)
    pull_p50: dict[int, float] = {}
    ranked: dict[str, Path] = {}

    if {"push", "pull", "cli", "export"} - set(args.skip):
        for size in (small, large):
            label = label_of(size)
            path = workdir / f"board-{size}.db"
            print(f"seeding {label} ...", file=sys.stderr, flush=True)
            seconds = seed_board(path, size, factory)
            floor = executemany_floor(path, workdir)
            report.add(f"seed {label} (as `drboard import` writes, {SEED_BATCH:,} a transaction)",
                       seconds, "s", floor=floor.wall,
                       floor_name="a plain executemany of the board file's rows into an empty "
                                  "schema, one transaction",
                       note=f"{size / seconds:,.0f} racers/s, records built included; database "
                            f"{path.stat().st_size / 2**20:,.1f} MiB")
            # Built before timing: the pushes' records, in memory.
            pushes = [factory.record(f"bench-push-{index:04d}")
                      for index in range(args.pushes + 5)]
            gc.collect()
            if "pull" not in args.skip:
                pull_p50[size] = bench_pull(report, path, size, label, args.pull_reps)
            if "cli" not in args.skip and size == large:
                bench_cli(report, path, workdir, label, args.cli_runs, command)
            if "export" not in args.skip and size == large:
                print(f"exporting {label} ...", file=sys.stderr, flush=True)
                exported = bench_export(report, path, workdir, label, args.transfer_runs, command)
                if "import" not in args.skip:
                    print(f"importing {label} ...", file=sys.stderr, flush=True)
                    bench_import(report, exported, workdir, label, args.transfer_runs)
                exported.unlink()
            if "push" not in args.skip:  # last: it adds racers to the board
                bench_push(report, path, label, pushes, warmup=5)
                ranked[label] = path
        if small in pull_p50 and large in pull_p50:
            ratio = pull_p50[large] / pull_p50[small]
            report.add(f"pull p50 ratio {label_of(large)} / {label_of(small)}", ratio, "x",
                       limit=PULL_SCALING_MAX, floor=1.0, floor_name="the same time at both sizes")

    if len(ranked) == 2:
        bench_rank(report, ranked, args.pull_reps)

    if "assemble" not in args.skip:
        print(f"assembling a {args.metrics_mb:g} MB run ...", file=sys.stderr, flush=True)
        bench_assemble(report, workdir, args.metrics_mb, args.assemble_runs, rng)
    return report


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.workdir:
        args.workdir.mkdir(parents=True, exist_ok=True)
        if any(args.workdir.iterdir()):
            raise SystemExit(f"--workdir {args.workdir} is not empty")
        report = run(args, args.workdir)
    else:
        with tempfile.TemporaryDirectory(prefix="drboard-bench-") as scratch:
            report = run(args, Path(scratch))
    config = report.config
    load = config["load_average"]
    report.print_summary(
        f"drboard local benchmark · Python {config['python']} · SQLite {config['sqlite']} · "
        f"{config['platform']} · {config['cpus']} CPUs"
        + (f" · load average {load[0]:.1f} at the start" if load else "")
        + (" · --quick" if args.quick else ""), args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
