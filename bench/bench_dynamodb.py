#!/usr/bin/env python3
"""Figures of drboard's DynamoDB store on Amazon's DynamoDB Local.

Not a test: it starts its own in-memory DynamoDB Local (as the integration tests do), seeds boards,
measures, and prints one table of figures with their targets (PASS/FAIL). See bench/README.md.

    python bench/bench_dynamodb.py            # boards of 1,000 and 100,000 racers
    python bench/bench_dynamodb.py --quick    # boards of 1,000 and 10,000 racers

Standard library, drboard and its dependencies (boto3), and the repository's test helpers
(tests/tablekit.py builds the table from template.yaml, so aws-sam-translator is needed:
``pip install -e '.[test]'``). DynamoDB Local's JAR is found as the tests find it.
"""

from __future__ import annotations

import argparse
import os
import platform
import random
import sys
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the tests package: DynamoDB Local and the table from the template

from drboard_functions import ranking  # noqa: E402
from drboard_functions.models import Board, Design, Entry, Score  # noqa: E402
from drboard_functions.service import LeaderboardService, racer_key  # noqa: E402
from drboard_functions.stores.dynamodb import RANK_INDEX, DynamoDbStore, board_item, entry_item  # noqa: E402

from tests.integration.dynamodb_local import DynamoDbLocal  # noqa: E402
from tests.tablekit import create_board_table  # noqa: E402

sys.path.insert(0, str(ROOT / "bench"))
from figures import Report, p50_p95, timed_ms  # noqa: E402

TRACK = "reInvent2019_track"
TABLE = "drboard-bench"
PAGE = 100

# ---- targets --------------------------------------------------------------------------------

ITEMS_READ_MAX_OVER = 1  # items read by a top-100 may exceed 100 by this much
PULL_SCALING_MAX = 1.5

# ---- figures (the same table as bench_local.py) -------------------------------------------------


# ---- seeding ----------------------------------------------------------------------------------

T0 = datetime(2025, 3, 1, 12, 0, tzinfo=UTC)
DESIGN = Design(algorithm="clipped_ppo", action_space="discrete", actions=14, max_speed=3.5,
                max_steering=30.0, sensors=["FRONT_FACING_CAMERA"])


def make_entry(board_id: str, n: int, rng: random.Random) -> Entry:
    """A racer's entry as push would store it: nine in ten qualified with a best lap of 8-30 s,
    the others off track at 1-99 % (as in bench_local.py); score and rank keys are genuine."""
    if rng.random() < 0.9:
        best = rng.randrange(8_000, 30_000)
        score = Score(qualified=True, time_ms=best, best_completion_pct=100.0, laps_completed=3,
                      best_lap_ms=best, run="metrics/evaluation/eval-1.json")
    else:
        score = Score(qualified=False, time_ms=None, best_completion_pct=float(rng.randrange(1, 100)),
                      laps_completed=0, best_lap_ms=None, run="metrics/evaluation/eval-1.json")
    racer = f"Bench Racer {n:06d}"
    key, when = racer_key(racer), T0 + timedelta(seconds=n)
    score_key = ranking.score_key(score)
    return Entry(board_id=board_id, racer=racer, racer_key=key, model_name="bench-model",
                 submission_id=f"{n:064x}", achieved_at=when, score=score, design=DESIGN,
                 score_key=score_key, rank_key=ranking.rank_key(score_key, when, key))


def seed_board(server: DynamoDbLocal, board_id: str, racers: int, threads: int, seed: int) -> float:
    """The board item and ``racers`` entry items, written directly: BatchWriteItem, 25 items a
    call, from ``threads`` threads with a client each. Returns the seconds taken."""
    start = time.perf_counter()
    rng = random.Random(seed)
    board = Board(board_id=board_id, track=TRACK, title=f"Bench board of {racers:,}", created_at=T0)
    items = [board_item(board) | {"participants": {"N": str(racers)}}]
    items += [entry_item(make_entry(board_id, n, rng)) for n in range(racers)]
    local = threading.local()

    def write(batch: list[dict[str, Any]]) -> None:
        if not hasattr(local, "client"):
            local.client = server.client()
        requests = [{"PutRequest": {"Item": item}} for item in batch]
        while requests:
            response = local.client.batch_write_item(RequestItems={TABLE: requests})
            requests = response.get("UnprocessedItems", {}).get(TABLE, [])

    with ThreadPoolExecutor(threads) as pool:
        list(pool.map(write, (items[i:i + 25] for i in range(0, len(items), 25))))
    return time.perf_counter() - start


# ---- measuring -------------------------------------------------------------------------------


class Probe:
    """One size's board, read through the store and the service on a client that counts items."""

    def __init__(self, server: DynamoDbLocal, size: int) -> None:
        self.size, self.label, self.board_id = size, f"{size:,} racers", f"bench_{size}"
        self.client = server.client()
        self.scanned: list[int] = []
        self.client.meta.events.register("after-call.dynamodb.Query", self._count)
        self.store = DynamoDbStore(TABLE, self.client)
        self.service = LeaderboardService(self.store)
        self.bare_request: dict[str, Any] = {
            "TableName": TABLE, "IndexName": RANK_INDEX, "ConsistentRead": True, "Limit": PAGE,
            "KeyConditionExpression": "board = :b",
            "ExpressionAttributeValues": {":b": {"S": self.board_id}},
        }

    def _count(self, parsed: dict[str, Any], **_: Any) -> None:
        self.scanned.append(int(parsed.get("ScannedCount", 0)))

    def page(self) -> None:
        self.service.board_page(self.board_id, limit=PAGE)

    def top(self) -> None:
        self.store.top(self.board_id, PAGE)

    def bare(self) -> None:
        self.client.query(**self.bare_request)


def interleaved(probes: list[Probe], call: Callable[[Probe], None], reps: int) -> list[list[float]]:
    """``reps`` timed calls per probe, alternating between them so that drift (JIT, GC, other
    load on the machine) falls on every size alike."""
    samples: list[list[float]] = [[] for _ in probes]
    for _ in range(reps):
        for index, probe in enumerate(probes):
            samples[index].append(timed_ms(lambda probe=probe: call(probe)))
    return samples


def run(report: Report, server: DynamoDbLocal, args: argparse.Namespace) -> None:
    for size in args.sizes:
        print(f"seeding {size:,} racers ...", file=sys.stderr, flush=True)
        seconds = seed_board(server, f"bench_{size}", size, args.threads, args.seed + size)
        report.add(f"seed {size:,} racers (BatchWriteItem, {args.threads} threads)", seconds, "s",
                   note=f"{size / seconds:,.0f} entries/s")
    probes = [Probe(server, size) for size in args.sizes]

    for probe in probes:
        probe.scanned.clear()
        top = probe.store.top(probe.board_id, PAGE)
        assert len(top) == PAGE and [e.rank_key for e in top] == sorted(e.rank_key for e in top)
        read = sum(probe.scanned)
        report.add(f"items read by store.top({PAGE}) @ {probe.label}", read, "items",
                   ok=PAGE <= read <= PAGE + ITEMS_READ_MAX_OVER,
                   target=f"{PAGE}-{PAGE + ITEMS_READ_MAX_OVER}",
                   note=f"ScannedCount summed over {len(probe.scanned)} Query call(s)")

    print(f"warming up ({args.warmup} pages per size) ...", file=sys.stderr, flush=True)
    interleaved(probes, Probe.page, args.warmup)
    pages = interleaved(probes, Probe.page, args.reps)
    tops = interleaved(probes, Probe.top, args.reps)
    bares = interleaved(probes, Probe.bare, args.reps)
    p50s, bare_p50s = [], []
    for probe, page, top_ms, bare in zip(probes, pages, tops, bares, strict=True):
        p50, p95 = p50_p95(page)
        p50s.append(p50)
        bare_p50s.append(p50_p95(bare)[0])
        report.add(f"board_page(limit={PAGE}) p50 @ {probe.label}", p50, "ms")
        report.add(f"board_page(limit={PAGE}) p95 @ {probe.label}", p95, "ms")
        report.add(f"  of which store.top({PAGE}) p50 @ {probe.label}", p50_p95(top_ms)[0], "ms")
        report.add(f"  bare boto3 Query of the same {PAGE} p50 @ {probe.label}", bare_p50s[-1], "ms",
                   note="the Query alone: no parsing of entries, no board read, no views")
    (small, large) = args.sizes
    ratio = p50s[1] / p50s[0]
    report.add(f"board_page p50 ratio {large:,} / {small:,} racers", ratio, "x",
               ok=ratio <= PULL_SCALING_MAX, target=f"<= {PULL_SCALING_MAX:.2f} x")
    report.add(f"bare Query p50 ratio {large:,} / {small:,} racers", bare_p50s[1] / bare_p50s[0], "x")

    # No target: the rank count a push runs (count_better) reads every better entry, so its cost
    # grows with the racer's rank. A best lap of 19 s lands mid-board (laps are drawn from 8-30 s).
    middle = ranking.score_key(Score(qualified=True, time_ms=19_000, best_completion_pct=100.0,
                                     laps_completed=3, best_lap_ms=19_000, run="x"))
    for probe in probes:
        probe.scanned.clear()
        counts = [timed_ms(lambda probe=probe: probe.store.count_better(probe.board_id, middle))
                  for _ in range(args.count_reps)]
        per_count = sum(probe.scanned) // args.count_reps
        report.add(f"count_better (a mid-board push's rank) p50 @ {probe.label}", p50_p95(counts)[0],
                   "ms", note=f"{per_count:,} items read per count, in "
                              f"{len(probe.scanned) // args.count_reps} Query page(s)")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="boards of 1,000 and 10,000 racers")
    parser.add_argument("--sizes", type=int, nargs=2, metavar=("SMALL", "LARGE"))
    parser.add_argument("--reps", type=int, default=200, help="timed calls per figure (200)")
    parser.add_argument("--warmup", type=int, default=100, help="untimed pages per size first (100)")
    parser.add_argument("--count-reps", type=int, default=5)
    parser.add_argument("--threads", type=int, default=8, help="seeding threads (8)")
    parser.add_argument("--seed", type=int, default=20250301)
    parser.add_argument("--json", type=Path, help="also save the figures here")
    args = parser.parse_args(argv)
    args.sizes = args.sizes or ([1_000, 10_000] if args.quick else [1_000, 100_000])
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    report = Report(config={
        "sizes": args.sizes, "reps": args.reps, "quick": args.quick, "python": sys.version.split()[0],
        "platform": platform.platform(), "cpus": os.cpu_count(),
        "started_at": datetime.now(UTC).isoformat(timespec="seconds"),
    })
    with DynamoDbLocal() as server:
        report.config["dynamodb_local"] = str(server.jar)
        print(f"DynamoDB Local at {server.endpoint}: {' '.join(server.command(server.port))}",
              file=sys.stderr, flush=True)
        create_board_table(server.client(), TABLE)
        run(report, server, args)

    config = report.config
    report.print_summary(
        f"drboard DynamoDB benchmark · DynamoDB Local ({Path(config['dynamodb_local']).parent.name}) · "
        f"Python {config['python']} · {config['platform']} · {config['cpus']} CPUs"
        + (" · --quick" if args.quick else ""), args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
