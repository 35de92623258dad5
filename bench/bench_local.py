#!/usr/bin/env python3
"""Local performance figures of drboard on the embedded SQLite board.

Not a test: it builds boards and a large run folder in a temporary folder, measures, and prints
one table of figures with their targets (PASS/FAIL). See bench/README.md.

    python bench/bench_local.py            # full run: 1,000 and 100,000 racers, 50 MB metrics
    python bench/bench_local.py --quick    # smoke run: 1,000 and 10,000 racers, 5 MB metrics
    python bench/bench_local.py --json figures.json

Standard library only, plus the drboard packages themselves.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import random
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

from drboard_assembler import __version__ as ASSEMBLER_VERSION
from drboard_assembler.design import load_design
from drboard_assembler.record import EvaluationRun, Lap, Record, SourceFile
from drboard_functions import ranking
from drboard_functions.models.domain import Entry, Submission
from drboard_functions.service import LeaderboardService, racer_key
from drboard_functions.stores import rank_buckets
from drboard_functions.stores.sqlite import SqliteStore
from drboard_functions.views import design_of
from figures import Report, drboard_command, p50_p95, timed_ms

TRACK = "reInvent2019_track"  # "reInvent2019" resolves to it; its board id is the same
BOARD_ID = TRACK
MODEL = "bench-model"

# ---- targets --------------------------------------------------------------------------------

PULL_P50_MAX_MS = 10.0
PULL_SCALING_MAX = 1.5
PUSH_P50_MAX_MS = 10.0
RANK_SCALING_MAX = 1.5
CLI_PULL_P50_MAX_MS = 500.0
ASSEMBLE_MAX_S = 2.0
ASSEMBLE_PEAK_MAX_X = 10.0

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


# ---- figures --------------------------------------------------------------------------------


# ---- building records cheaply -----------------------------------------------------------------


class RecordFactory:
    """Distinct, fully valid Records that differ in racer and laps.

    The design is parsed once; each record is one EvaluationRun.from_laps and one Record.build
    (which validates and computes the submission id from the content). Records carry no training
    summary, which keeps them (and the seeded database) small; pull and push never read it.
    """

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng
        self.design = load_design(json.dumps(METADATA).encode(), "model/model_metadata.json",
                                  json.dumps(HYPERPARAMETERS).encode(), "ip/hyperparameters.json")
        self.provenance = [SourceFile(role="evaluation_metrics",
                                      path="metrics/EvaluationMetrics-20220709200242.json",
                                      sha256="0" * 64, bytes=1234)]

    def laps(self) -> list[Lap]:
        """Nine racers in ten complete three laps (best lap 8-30 s); the others go off track."""
        rng = self.rng
        if rng.random() < 0.9:
            base = rng.randint(8_000, 30_000)
            return [Lap(trial=k + 1, time_ms=base + rng.randint(0, 2_000), completion_pct=100,
                        status="Lap complete") for k in range(3)]
        return [Lap(trial=1, time_ms=rng.randint(1_000, 20_000),
                    completion_pct=rng.randint(1, 99), status="Off track")]

    def record(self, racer: str) -> Record:
        run = EvaluationRun.from_laps("metrics/EvaluationMetrics-20220709200242.json", self.laps())
        return Record.build(
            track=TRACK, racer=racer, model_name=MODEL, source_layout="drfc",
            assembler_version=ASSEMBLER_VERSION, evaluations=[run], design=self.design,
            training=None, provenance=self.provenance,
        )


def seed_board(path: Path, racers: int, factory: RecordFactory) -> float:
    """A board of ``racers`` racers in a new SQLite file; returns the seconds it took.

    The first racer goes through LeaderboardService.push (which creates the board); the others
    are written with the store's own record_submission, with the Submission and Entry built as
    push builds them, but without push's rank count (which would make seeding quadratic).
    """
    start = time.perf_counter()
    store = SqliteStore(path)
    service = LeaderboardService(store)
    service.push(factory.record("seed-000000"))
    board = store.get_board(BOARD_ID)
    assert board is not None
    rules = board.board.rules
    base = datetime(2024, 1, 1, tzinfo=UTC)
    for index in range(1, racers):
        record = factory.record(f"seed-{index:06d}")
        now = base + timedelta(seconds=index)
        score = ranking.score_record(record, rules)
        key = racer_key(record.racer)
        score_key = ranking.score_key(score)
        submission = Submission(
            board_id=BOARD_ID, racer=record.racer, racer_key=key,
            submission_id=record.submission_id, model_name=record.model_name,
            submitted_at=now, score=score, score_key=score_key,
        )
        entry = Entry(
            board_id=BOARD_ID, racer=record.racer, racer_key=key,
            model_name=record.model_name, submission_id=record.submission_id,
            achieved_at=now, score=score, design=design_of(record), score_key=score_key,
            rank_key=ranking.rank_key(score_key, now, key),
        )
        outcome = store.record_submission(submission, record, entry)
        assert outcome.improved and not outcome.duplicate
    store.close()
    elapsed = time.perf_counter() - start
    with sqlite3.connect(path) as check:
        check.execute("PRAGMA wal_checkpoint(TRUNCATE)")
    stored = SqliteStore(path)
    participants = LeaderboardService(stored).board_page(BOARD_ID, limit=1).board.participants
    stored.close()
    assert participants == racers, (participants, racers)
    return elapsed


# ---- 1 and 2: push and pull in-process ----------------------------------------------------------


def bench_pull(report: Report, path: Path, size: int, label: str, reps: int) -> float:
    store = SqliteStore(path)
    service = LeaderboardService(store)
    for _ in range(10):  # warm: page cache, statement cache, imports
        service.board_page(BOARD_ID, limit=100)
    page = service.board_page(BOARD_ID, limit=100)
    assert len(page.entries) == 100 and page.board.participants == size
    samples = [timed_ms(lambda: service.board_page(BOARD_ID, limit=100)) for _ in range(reps)]
    p50, p95 = p50_p95(samples)
    report.add(f"pull top-100 p50 @ {label}", p50, "ms", limit=PULL_P50_MAX_MS)
    report.add(f"pull top-100 p95 @ {label}", p95, "ms")
    # Where a page's time goes: the store's read (SQL + Entry parsing) versus the rest.
    top = [timed_ms(lambda: store.top(BOARD_ID, 100)) for _ in range(reps)]
    report.add(f"  of which store.top(100) p50 @ {label}", p50_p95(top)[0], "ms")
    store.close()
    return p50


def bench_push(report: Report, path: Path, label: str, records: list[Record],
               warmup: int) -> None:
    store = SqliteStore(path)
    service = LeaderboardService(store)
    for record in records[:warmup]:
        service.push(record)
    samples = []
    ranks = []
    for record in records[warmup:]:
        start = time.perf_counter()
        receipt = service.push(record)
        samples.append((time.perf_counter() - start) * 1000)
        assert receipt.status == "created"
        ranks.append(receipt.rank / receipt.participants)
    p50, p95 = p50_p95(samples)
    report.add(f"push new racer p50 @ {label}", p50, "ms", limit=PUSH_P50_MAX_MS,
               note=f"{len(samples)} pushes after {warmup} warm-up ones; lap times drawn like "
                    f"the seeded racers' (median rank at {statistics.median(ranks):.0%} of "
                    "the board)")
    report.add(f"push new racer p95 @ {label}", p95, "ms")
    # The one query in push whose cost grows with the board: the rank count.
    keys = [ranking.score_key(ranking.score_record(r, store.get_board(BOARD_ID).board.rules))
            for r in records[warmup:]]
    counts = [timed_ms(lambda k=k: store.count_better(BOARD_ID, k)) for k in keys]
    report.add(f"  of which count_better p50 @ {label}", p50_p95(counts)[0], "ms")
    store.close()


def bench_rank(report: Report, boards: dict[str, Path], reps: int) -> None:
    """Ranks on each board (label -> file): a mid-board push's (a 19 s lap; laps are drawn from
    8-30 s) and the last racer's, which a public read of them (``racer``) counts. Rows read are
    those of the counts a rank adds up; for comparison, the entries the count read before them.
    Timed alternately on the boards, so that drift (other load on the machine) falls on each."""
    middle = _lap_record("bench-rank-middle", [19_000, 19_500, 20_000], 100)
    last = _lap_record("bench-rank-last", [9_000], 0.5)  # below every seeded racer
    stores = {label: SqliteStore(path) for label, path in boards.items()}
    calls: dict[str, list[Callable[[], object]]] = {name: [] for name in (
        "mid-board push's rank", "last racer's rank", "racer view of the last racer")}
    for label, store in stores.items():
        service = LeaderboardService(store)
        rules = store.get_board(BOARD_ID).board.rules
        mid = service.push(middle)
        service.push(last)
        view = service.racer(BOARD_ID, last.racer)
        assert view.entry.rank == view.board.participants
        for name, record, rank in (("mid-board push's rank", middle, mid.rank),
                                   ("last racer's rank", last, view.entry.rank)):
            key = ranking.score_key(ranking.score_record(record, rules))
            rows, entries = _rows_read(boards[label], key)
            report.add(f"rows read by the {name} (rank {rank:,}) @ {label}", rows, "rows",
                       note=f"counts summed; the count before them read {entries:,} entries")
            calls[name].append(lambda store=store, key=key: store.count_better(BOARD_ID, key))
        calls["racer view of the last racer"].append(
            lambda service=service: service.racer(BOARD_ID, last.racer))
    for name, per_board in calls.items():
        batch = 1 if name.startswith("racer view") else 100  # a rank takes microseconds
        samples: list[list[float]] = [[] for _ in per_board]
        for _ in range(reps):
            for index, call in enumerate(per_board):
                samples[index].append(_timed_batch(call, batch))
        p50s = [p50_p95(timings)[0] for timings in samples]
        for label, p50 in zip(boards, p50s, strict=True):
            report.add(f"{name} p50 @ {label}", p50, "ms")
        small, large = boards
        report.add(f"{name} p50 ratio {large} / {small}", p50s[1] / p50s[0], "x",
                   limit=RANK_SCALING_MAX)
    for store in stores.values():
        store.close()


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
    run = EvaluationRun.from_laps("metrics/EvaluationMetrics-20220709200242.json", laps)
    factory = RecordFactory(random.Random(0))
    return Record.build(track=TRACK, racer=racer, model_name=MODEL, source_layout="drfc",
                        assembler_version=ASSEMBLER_VERSION, evaluations=[run],
                        design=factory.design, training=None, provenance=factory.provenance)


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


def bench_cli(report: Report, path: Path, label: str, runs: int, command: list[str]) -> None:
    env = dict(os.environ, DRBOARD_DB=str(path), COLUMNS="160")
    env.pop("NO_COLOR", None)
    for fmt in ("json", "table"):
        argv = [*command, "pull", "--board", BOARD_ID, "--top", "100", "--format", fmt]
        samples = []
        for run in range(runs + 2):  # two warm-up runs: the OS caches the files and .pyc
            start = time.perf_counter()
            done = subprocess.run(argv, env=env, capture_output=True, check=False)
            elapsed = (time.perf_counter() - start) * 1000
            if done.returncode != 0:
                raise SystemExit(f"{' '.join(argv)} failed ({done.returncode}):\n"
                                 + done.stderr.decode(errors="replace"))
            if run == 0 and fmt == "json":
                assert len(json.loads(done.stdout)["entries"]) == 100
            if run >= 2:
                samples.append(elapsed)
        p50, p95 = p50_p95(samples)
        report.add(f"`drboard pull --top 100 --format {fmt}` p50 @ {label}", p50, "ms",
                   limit=CLI_PULL_P50_MAX_MS)
        report.add(f"`drboard pull --top 100 --format {fmt}` p95 @ {label}", p95, "ms")
    # The floor under every command: starting Python and importing the CLI and the service.
    floor = [sys.executable, "-c",
             "import drboard_cli.main, drboard_functions.service, drboard_functions.stores.sqlite"]
    samples = []
    for run in range(runs + 2):
        start = time.perf_counter()
        subprocess.run(floor, env=env, check=True)
        if run >= 2:
            samples.append((time.perf_counter() - start) * 1000)
    report.add("  of which python start + imports p50", p50_p95(samples)[0], "ms")


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


# Runs in a fresh interpreter: import first, then measure RSS, assemble, and measure the peak.
ASSEMBLE_CHILD = textwrap.dedent("""
    import gc, json, resource, sys, time
    from pathlib import Path
    from drboard_assembler import Overrides, assemble

    def rss_kib():
        try:
            with open("/proc/self/status") as status:
                for line in status:
                    if line.startswith("VmRSS:"):
                        return int(line.split()[1])
        except OSError:
            pass
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return peak // 1024 if sys.platform == "darwin" else peak

    def peak_kib():
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return peak // 1024 if sys.platform == "darwin" else peak

    gc.collect()
    before = rss_kib()
    peak_before = peak_kib()
    start = time.perf_counter()
    record = assemble(Path(sys.argv[1]), Overrides(track="reInvent2019", racer="Bench",
                                                   race_type="time_trial"))
    seconds = time.perf_counter() - start
    peak_after = peak_kib()
    print(json.dumps({
        "seconds": seconds, "rss_before_kib": before, "peak_before_kib": peak_before,
        "peak_after_kib": peak_after, "episodes": record.training.episodes,
        "best_lap_ms": record.best_run.best_lap_ms, "record_bytes": len(record.model_dump_json()),
    }))
""")


def bench_assemble(report: Report, workdir: Path, megabytes: float, runs: int,
                   rng: random.Random) -> None:
    root = workdir / "big-run"
    start = time.perf_counter()
    size, episodes = write_run_folder(root, int(megabytes * 1_000_000), rng)
    print(f"  wrote {size / 1e6:.1f} MB TrainingMetrics.json ({episodes:,} training episodes) "
          f"in {time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)
    results = []
    for _ in range(runs):
        done = subprocess.run([sys.executable, "-c", ASSEMBLE_CHILD, str(root)],
                              capture_output=True, check=False, text=True)
        if done.returncode != 0:
            raise SystemExit(f"assembling {root} failed:\n{done.stderr}")
        result = json.loads(done.stdout)
        assert result["episodes"] == episodes, (result["episodes"], episodes)
        results.append(result)
    seconds = statistics.median(r["seconds"] for r in results)
    increase = max(r["peak_after_kib"] - r["rss_before_kib"] for r in results) * 1024
    label = f"{size / 1e6:.0f} MB"
    report.add(f"assemble {label} run: wall time (median of {runs})", seconds, "s",
               limit=ASSEMBLE_MAX_S)
    report.add(f"assemble {label} run: peak RSS increase", increase / 2**20, "MiB")
    report.add(f"assemble {label} run: peak RSS increase / file size", increase / size, "x",
               limit=ASSEMBLE_PEAK_MAX_X)
    report.config["assemble"] = {"training_file_bytes": size, "training_episodes": episodes,
                                 "runs": results}


# ---- 5: export of a whole board -----------------------------------------------------------------


EXPORT_VS_DUMP_MAX_X = 10.0


def bench_export(report: Report, path: Path, workdir: Path, label: str) -> None:
    """`drboard export` of the board in-process (the embedded target, written to a file) against
    a plain dump of the same SQLite file (every row of every table, as SQL text)."""
    from drboard_cli import transfer

    store = SqliteStore(path)
    service = LeaderboardService(store)
    exported = workdir / "export.jsonl"
    start = time.perf_counter()
    with exported.open("w", encoding="utf-8") as out:
        counts = transfer.write_export(service, BOARD_ID, out)
    export_s = time.perf_counter() - start
    store.close()

    dumped = workdir / "dump.sql"
    start = time.perf_counter()
    with sqlite3.connect(path) as db, dumped.open("w", encoding="utf-8") as out:
        for statement in db.iterdump():
            out.write(statement + "\n")
    dump_s = time.perf_counter() - start
    report.add(f"export {label} (write_export to a file)", export_s, "s",
               note=f"{counts.entries:,} entries, {counts.submissions:,} submissions, "
                    f"{exported.stat().st_size / 2**20:,.1f} MiB")
    report.add(f"plain dump {label} (sqlite3 iterdump to a file)", dump_s, "s",
               note=f"{dumped.stat().st_size / 2**20:,.1f} MiB")
    report.add(f"export / plain dump {label}", export_s / dump_s, "x", limit=EXPORT_VS_DUMP_MAX_X)
    exported.unlink()
    dumped.unlink()


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
    parser.add_argument("--drboard", metavar="PATH",
                        help="the drboard executable (default: the one beside this Python)")
    parser.add_argument("--workdir", type=Path,
                        help="build the boards and run folder here and keep them "
                             "(default: a temporary folder, removed afterwards)")
    parser.add_argument("--seed", type=int, default=2019, help="random seed (default 2019)")
    parser.add_argument("--skip", choices=["push", "pull", "cli", "assemble", "export"],
                        action="append",
                        default=[], help="skip a part (repeatable)")
    args = parser.parse_args(argv)
    quick = args.quick
    args.sizes = args.sizes or ([1_000, 10_000] if quick else [1_000, 100_000])
    args.metrics_mb = args.metrics_mb or (5.0 if quick else 50.0)
    args.pull_reps = args.pull_reps or (100 if quick else 300)
    args.pushes = args.pushes or (50 if quick else 200)
    args.cli_runs = args.cli_runs or (5 if quick else 15)
    args.assemble_runs = args.assemble_runs or (1 if quick else 3)
    return args


def label_of(size: int) -> str:
    return f"{size:,} racers"


def run(args: argparse.Namespace, workdir: Path) -> Report:
    report = Report(config={
        "sizes": args.sizes, "metrics_mb": args.metrics_mb, "pull_reps": args.pull_reps,
        "pushes": args.pushes, "cli_runs": args.cli_runs, "assemble_runs": args.assemble_runs,
        "quick": args.quick, "python": sys.version.split()[0], "sqlite": sqlite3.sqlite_version,
        "platform": platform.platform(), "cpus": os.cpu_count(),
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
            report.add(f"seed {label} (record_submission, one transaction each)", seconds, "s",
                       note=f"{size / seconds:,.0f} racers/s; database "
                            f"{path.stat().st_size / 2**20:,.1f} MiB")
            # Built before timing: the pushes' records, in memory.
            pushes = [factory.record(f"bench-push-{index:04d}")
                      for index in range(args.pushes + 5)]
            gc.collect()
            if "pull" not in args.skip:
                pull_p50[size] = bench_pull(report, path, size, label, args.pull_reps)
            if "cli" not in args.skip and size == large:
                bench_cli(report, path, label, args.cli_runs, command)
            if "export" not in args.skip and size == large:
                bench_export(report, path, workdir, label)
            if "push" not in args.skip:  # last: it adds racers to the board
                bench_push(report, path, label, pushes, warmup=5)
                ranked[label] = path
        if small in pull_p50 and large in pull_p50:
            ratio = pull_p50[large] / pull_p50[small]
            report.add(f"pull p50 ratio {label_of(large)} / {label_of(small)}", ratio, "x",
                       limit=PULL_SCALING_MAX)

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
    report.print_summary(
        f"drboard local benchmark · Python {config['python']} · SQLite {config['sqlite']} · "
        f"{config['platform']} · {config['cpus']} CPUs" + (" · --quick" if args.quick else ""),
        args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
