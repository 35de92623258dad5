#!/usr/bin/env python3
"""Figures of drboard's DynamoDB store on Amazon's DynamoDB Local.

Not a test: it starts its own in-memory DynamoDB Local (as the integration tests do), seeds boards,
measures, and prints one table of figures with their targets (PASS/FAIL). See bench/README.md.

    python bench/bench_dynamodb.py            # boards of 1,000 and 100,000 racers
    python bench/bench_dynamodb.py --quick    # boards of 1,000 and 10,000 racers
    python bench/bench_dynamodb.py --only-ranks  # ranks and contention, without the page figures
    python bench/bench_dynamodb.py --only-contention  # 16 threads pushing to one board

Standard library, drboard and its dependencies (boto3), and the repository's test helpers
(tests/tablekit.py builds the table from template.yaml, so aws-sam-translator is needed:
``pip install -e '.[test]'``). DynamoDB Local's JAR is found as the tests find it.
"""

from __future__ import annotations

import argparse
import os
import platform
import random
import statistics
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any, NamedTuple

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the tests package: DynamoDB Local and the table from the template

from click.testing import CliRunner  # noqa: E402
from drboard_cli.commands.organisers import LOCAL_REBUILD_STEP_S  # noqa: E402
from drboard_cli.main import cli  # noqa: E402
from drboard_cli.transfer import IMPORT_BATCH  # noqa: E402  (as `drboard import` loads them)
from drboard_functions import ranking  # noqa: E402
from drboard_functions.models.domain import Board, Design, Entry, Score  # noqa: E402
from drboard_functions.models.organiser_views import RankCounters  # noqa: E402
from drboard_functions.models.requests import ImportedSubmission  # noqa: E402
from drboard_functions.service import LeaderboardService, racer_key  # noqa: E402
from drboard_functions.stores.base import RankBuild  # noqa: E402
from drboard_functions.stores.dynamodb import (  # noqa: E402
    RANK_INDEX,
    DynamoDbStore,
    board_item,
    entry_item,
)
from drboard_functions.stores.dynamodb.ranks import BATCH_READ  # noqa: E402
from drboard_functions.stores.dynamodb.ranks import RankCounters as StoreCounters  # noqa: E402

from tests.integration.dynamodb_local import DynamoDbLocal  # noqa: E402
from tests.recordkit import make_record  # noqa: E402
from tests.tablekit import create_board_table  # noqa: E402

sys.path.insert(0, str(ROOT / "bench"))
from figures import Report, p50_p95, timed_ms  # noqa: E402

TRACK = "reInvent2019_track"
TABLE = "drboard-bench"
PAGE = 100

# ---- targets --------------------------------------------------------------------------------

ITEMS_READ_MAX_OVER = 1  # items read by a top-100 may exceed 100 by this much
PULL_SCALING_MAX = 1.5
RANK_ITEMS_MAX = 3  # items a rank reads once the board has its counters
RANK_SCALING_MAX = 1.5

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
    call, from ``threads`` threads with a client each (a board as before the rank counters).
    Returns the seconds taken."""
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
        self.server = server
        self.size, self.label, self.board_id = size, f"{size:,} racers", f"bench_{size}"
        self.last_racer = f"Last Racer {size}"  # pushed below every seeded racer
        self.last_key = ""  # their score key, once pushed
        self.pushes: list[Any] = []  # records of mid-board racers, pushed one by one
        self.push_reads: list[int] = []
        self.places: list[float] = []
        self.client = server.client()
        self.scanned: list[int] = []
        self.got = 0  # items read by GetItem and TransactGetItems
        self.client.meta.events.register("after-call.dynamodb.Query", self._count)
        self.client.meta.events.register("after-call.dynamodb.GetItem", self._count_got)
        self.client.meta.events.register("after-call.dynamodb.TransactGetItems", self._count_got)
        self.store = DynamoDbStore(TABLE, self.client)
        self.service = LeaderboardService(self.store)
        self.bare_request: dict[str, Any] = {
            "TableName": TABLE, "IndexName": RANK_INDEX, "ConsistentRead": True, "Limit": PAGE,
            "KeyConditionExpression": "board = :b",
            "ExpressionAttributeValues": {":b": {"S": self.board_id}},
        }

    def _count(self, parsed: dict[str, Any], **_: Any) -> None:
        self.scanned.append(int(parsed.get("ScannedCount", 0)))

    def _count_got(self, parsed: dict[str, Any], **_: Any) -> None:
        self.got += len(parsed["Responses"]) if "Responses" in parsed else int("Item" in parsed)

    def rank(self) -> None:
        self.store.count_better(self.board_id, MIDDLE)

    def last_rank(self) -> None:
        self.store.count_better(self.board_id, self.last_key)

    def racer_view(self) -> None:
        self.service.racer(self.board_id, self.last_racer)

    def push_next(self) -> None:
        """Push the next of ``pushes``; keep the items it read and where it ranked."""
        receipts: list[Any] = []
        reads = self.items_read(lambda: receipts.append(
            self.service.push(self.pushes.pop(0), self.board_id)))
        self.push_reads.append(sum(reads))
        self.places.append(receipts[0].rank / receipts[0].participants)

    def items_read(self, call: Callable[[], Any]) -> tuple[int, int]:
        """Items read by one call: (by Query, by GetItem and TransactGetItems)."""
        self.scanned.clear()
        self.got = 0
        call()
        return sum(self.scanned), self.got

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
    if args.only_contention:
        bench_contention(report, server, args)
        return
    if args.only_import:
        bench_import(report, server, args)
        return
    probes = []
    for size in args.sizes:
        print(f"seeding {size:,} racers ...", file=sys.stderr, flush=True)
        seconds = seed_board(server, f"bench_{size}", size, args.threads, args.seed + size)
        report.add(f"seed {size:,} racers (BatchWriteItem, {args.threads} threads)", seconds, "s",
                   note=f"{size / seconds:,.0f} entries/s")
        probes.append(Probe(server, size))
    bench_ranks(report, probes, args)
    bench_contention(report, server, args)
    if args.only_ranks:
        return
    bench_import(report, server, args)

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



def rebuild_ranks(report: Report, probe: Probe) -> None:
    """`drboard board rebuild-ranks BOARD` on a board from before the rank counters: the command
    itself (its loop of steps, each building for a few seconds, with progress), run in this
    process on the board's DynamoDB store, against its floor: one read of every entry's score
    key (what counting them takes at least), nothing written."""
    client = probe.server.client()
    calls = {"TransactWriteItems": 0, "UpdateItem": 0}

    def count(event_name: str, **_: Any) -> None:
        calls[event_name.rsplit(".", 1)[1]] += 1

    for operation in calls:
        client.meta.events.register(f"after-call.dynamodb.{operation}", count)
    service = LeaderboardService(DynamoDbStore(TABLE, client))
    steps: list[RankCounters] = []
    rebuild = service.rebuild_ranks

    def step(board_id: str, budget_s: float | None = None) -> RankCounters:
        steps.append(rebuild(board_id, budget_s))
        return steps[-1]

    service.rebuild_ranks = step  # type: ignore[method-assign]
    start = time.perf_counter()
    result = CliRunner().invoke(cli, ["--db", "unused.db", "board", "rebuild-ranks", probe.board_id],
                                obj=lambda _: service)
    seconds = time.perf_counter() - start
    if result.exit_code != 0:
        raise SystemExit(f"drboard board rebuild-ranks failed:\n{result.output}")
    assert steps[-1].done and steps[-1].counted == steps[-1].participants
    floor_start = time.perf_counter()
    # In pages of the build's own reads (DynamoDB Local reads a rank index's big pages slowly).
    counted = sum(page["Count"] for page in probe.store._pages({
        "TableName": TABLE, "IndexName": RANK_INDEX, "ConsistentRead": True, "Limit": BATCH_READ,
        "KeyConditionExpression": "board = :b AND rank_key > :first",
        "ExpressionAttributeValues": {":b": {"S": probe.board_id}, ":first": {"S": "0"}},
        "ProjectionExpression": "score_key"}))
    floor = time.perf_counter() - floor_start
    report.add(f"`drboard board rebuild-ranks` (once per board from before them) @ {probe.label}",
               seconds, "s", floor=floor,
               floor_name="one Query through every entry's score key (pages of the build's "
                          f"{BATCH_READ}), nothing written",
               note=f"{len(steps)} steps of up to {LOCAL_REBUILD_STEP_S:g} s, "
                    f"{calls['TransactWriteItems']:,} batches (a transaction each, "
                    f"{counted / max(calls['TransactWriteItems'], 1):,.0f} entries a batch), "
                    f"{steps[-1].participants:,} racers counted")


# A best lap of 19 s lands mid-board (laps are drawn from 8-30 s).
MIDDLE = ranking.score_key(Score(qualified=True, time_ms=19_000, best_completion_pct=100.0,
                                 laps_completed=3, best_lap_ms=19_000, run="x"))


def bench_ranks(report: Report, probes: list[Probe], args: argparse.Namespace) -> None:
    """Ranks on boards seeded as before the counters: one count from the entries (what every
    rank cost before), the one-time build of the counters, then ranks from the counters."""
    for probe in probes:
        start = time.perf_counter()
        queried, _ = probe.items_read(lambda probe=probe: probe.store.count_better(probe.board_id, MIDDLE))
        report.add(f"count_better mid-board, counted from the entries @ {probe.label}",
                   (time.perf_counter() - start) * 1000, "ms",
                   note=f"{queried:,} items read (a board before the counters; before them, every board)")
        rebuild_ranks(report, probe)
        # Seeded racers have entries only; the last racer (0.5 % done) is pushed, record and all.
        probe.service.push(make_record(probe.last_racer, [(9_000, 0.5)]), probe.board_id)
        last = probe.store.get_entry(probe.board_id, racer_key(probe.last_racer))
        assert last is not None
        probe.last_key = last.score_key

    for probe in probes:
        probe.pushes = [make_record(f"Mid Pusher {probe.size} {n:03d}", [(19_000 + n, 100)])
                        for n in range(args.pushes)]
        rank_reads = probe.items_read(probe.rank)
        last_reads = probe.items_read(probe.last_rank)
        racer_reads = probe.items_read(probe.racer_view)
        view = probe.service.racer(probe.board_id, probe.last_racer)
        assert view.entry.rank == view.board.participants  # below every seeded racer
        report.add(f"items read by a mid-board rank (count_better) @ {probe.label}", sum(rank_reads),
                   "items", ok=sum(rank_reads) <= RANK_ITEMS_MAX, target=f"<= {RANK_ITEMS_MAX}",
                   note=f"{rank_reads[0]} by Query, {rank_reads[1]} by GetItem/TransactGetItems")
        report.add(f"items read by the last racer's rank (count_better) @ {probe.label}",
                   sum(last_reads), "items", ok=sum(last_reads) <= RANK_ITEMS_MAX,
                   target=f"<= {RANK_ITEMS_MAX}")
        report.add(f"items read by a racer view of the last racer (rank {view.entry.rank:,}) @ "
                   f"{probe.label}", sum(racer_reads), "items",
                   note="the whole view: board, entry, record, history, leader and the rank")
    interleaved(probes, Probe.rank, args.count_reps)  # warm-up
    timed = {"rank": interleaved(probes, Probe.rank, args.count_reps),
             "last": interleaved(probes, Probe.last_rank, args.count_reps),
             "racer": interleaved(probes, Probe.racer_view, args.count_reps),
             "push": interleaved(probes, Probe.push_next, args.pushes)}
    figures = {name: [p50_p95(samples)[0] for samples in per_probe] for name, per_probe in timed.items()}
    for index, probe in enumerate(probes):
        report.add(f"count_better mid-board p50 @ {probe.label}", figures["rank"][index], "ms")
        report.add(f"count_better of the last racer p50 @ {probe.label}", figures["last"][index], "ms")
        report.add(f"racer view of the last racer p50 @ {probe.label}", figures["racer"][index], "ms",
                   note="the rank and the view's other reads (history, record, leader, board)")
        report.add(f"push of a new mid-board racer p50 @ {probe.label}", figures["push"][index], "ms",
                   note=f"{args.pushes} pushes; {max(probe.push_reads)} items read at most per push, "
                        f"the rank in its receipt included; ranked at "
                        f"{statistics.median(probe.places):.0%} of the board")
    (small, large) = args.sizes
    for name, label in (("rank", "count_better mid-board"), ("last", "count_better of the last racer"),
                        ("push", "push of a mid-board racer"), ("racer", "racer view of the last racer")):
        ratio = figures[name][1] / figures[name][0]
        # The racer view's own reads (its history Query above all) take longer on DynamoDB
        # Local's bigger partition, for the same items read: a figure, not a target.
        checked = name != "racer"
        report.add(f"{label} p50 ratio {large:,} / {small:,} racers", ratio, "x",
                   ok=ratio <= RANK_SCALING_MAX if checked else None,
                   target=f"<= {RANK_SCALING_MAX:.2f} x" if checked else "")


class NeverBuilt(StoreCounters):
    def build(self, board_id: str, max_racers: int | None = None,
              budget_s: float | None = None) -> RankBuild:
        return RankBuild(done=False, counted=0, participants=0)


class NoCounters(DynamoDbStore):
    """The store as it was before the rank counters: pushes move no counter, ranks count the
    better entries (on a board without counters)."""

    def __init__(self, table_name: str, client: Any = None) -> None:
        super().__init__(table_name, client)
        self.ranks = NeverBuilt(self.client, table_name)


def bench_contention(report: Report, server: DynamoDbLocal, args: argparse.Namespace) -> None:
    """``--pushers`` threads, a client each, push at once to one new board: each a new racer,
    then improvements in the same few buckets. With the counters, and as before them."""
    for name, store_type in (("with rank counters", DynamoDbStore), ("without (as before)", NoCounters)):
        run = contend(server, store_type, args)
        report.add(f"{args.pushers} threads x {args.pushes_each} pushes to one board, {name}",
                   run.pushes_per_s, "pushes/s",
                   ok=(run.exact and not run.gave_up) if store_type is DynamoDbStore else None,
                   note=f"{run.cancelled} of {run.transactions} push transactions cancelled "
                        f"(conflicts) and retried; {run.gave_up} pushes failed; ranks exact "
                        f"afterwards: {run.exact}")


class Contention(NamedTuple):
    pushes_per_s: float
    transactions: int
    cancelled: int
    gave_up: int
    exact: bool


def contend(server: DynamoDbLocal, store_type: type[DynamoDbStore], args: argparse.Namespace) -> Contention:
    board_id = f"contention_{store_type.__name__}"
    client = server.client()
    board = Board(board_id=board_id, track=TRACK, title="Contention", created_at=T0)
    if store_type is DynamoDbStore:
        DynamoDbStore(TABLE, client).create_board(board)
    else:
        client.put_item(TableName=TABLE, Item=board_item(board))
    stores = [store_type(TABLE, server.client()) for _ in range(args.pushers)]
    counts = {"transactions": 0, "cancelled": 0}
    lock = threading.Lock()

    def count(parsed: dict[str, Any], **_: Any) -> None:
        with lock:
            counts["transactions"] += 1
            counts["cancelled"] += parsed.get("Error", {}).get("Code") == "TransactionCanceledException"

    for store in stores:
        store.client.meta.events.register("after-call.dynamodb.TransactWriteItems", count)
    rng = random.Random(args.seed)
    work = [[make_record(f"{board_id} {t:02d}", [(11_000 + rng.choice([0, 4, 9, 500]) - k * 3, 100)],
                         model=f"m{k}") for k in range(args.pushes_each)] for t in range(args.pushers)]
    barrier = threading.Barrier(args.pushers)
    gave_up: list[Exception] = []

    def push(t: int) -> None:
        service = LeaderboardService(stores[t])
        barrier.wait(timeout=60)
        for record in work[t]:
            try:
                service.push(record, board_id)
            except Exception as error:  # StoreContention (gave up retrying) above all
                gave_up.append(error)

    threads = [threading.Thread(target=push, args=(t,)) for t in range(args.pushers)]
    start = time.perf_counter()
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    seconds = time.perf_counter() - start
    check = DynamoDbStore(TABLE, server.client())
    entries = check.top(board_id, 1000)
    exact = len(entries) == args.pushers and all(
        check.count_better(board_id, e.score_key) == sum(o.score_key < e.score_key for o in entries)
        for e in entries)
    return Contention(args.pushers * args.pushes_each / seconds, counts["transactions"],
                      counts["cancelled"], len(gave_up), exact)


def bench_import(report: Report, server: DynamoDbLocal, args: argparse.Namespace) -> None:
    """An export's submissions imported into a new board in bulk (LeaderboardService.bulk_import,
    as `drboard import` loads an embedded board: BatchWriteItem for records, audit events and
    the near-copy index, one TransactWriteItems per 12 submissions for what must stay
    consistent), and one by one as a deployed board's import route replays them (a push's
    transaction each), against a floor: BatchWriteItem of the board's own items the bulk import
    ends with, 25 a call, from one thread. Both boards are checked to rank alike."""
    from bench_local import RecordFactory

    factory = RecordFactory(random.Random(args.seed))
    items = [ImportedSubmission.model_construct(submitted_at=T0 + timedelta(seconds=n),
                                                record=factory.record(f"importer-{n:06d}"))
             for n in range(args.import_racers)]
    label = f"{len(items):,} racers"
    runs: dict[str, tuple[float, Counter[str]]] = {}
    for way in ("bulk", "replay"):
        client = server.client()
        calls: Counter[str] = Counter()
        client.meta.events.register("after-call.dynamodb", lambda event_name, calls=calls, **_:
                                    calls.update([event_name.rsplit(".", 1)[1]]))
        service = LeaderboardService(DynamoDbStore(TABLE, client))
        board = Board(board_id=f"imported_{way}", track=TRACK, title="Imported", created_at=T0)
        print(f"importing {label} ({way}) ...", file=sys.stderr, flush=True)
        start = time.perf_counter()
        if way == "bulk":
            bulk = service.bulk_import(board)
            prepared = [bulk.prepare(item) for item in items]
            bulk.open()
            for first in range(0, len(prepared), IMPORT_BATCH):
                bulk.load(prepared[first:first + IMPORT_BATCH])
        else:
            service.import_board(board)
            for item in items:
                service.import_submission(board.board_id, item)
        runs[way] = (time.perf_counter() - start, calls)
    check = DynamoDbStore(TABLE, server.client())
    ranked = [[(e.racer, check.count_better(f"imported_{way}", e.score_key)) for e in
               check.top(f"imported_{way}", 50)] for way in ("bulk", "replay")]
    assert ranked[0] == ranked[1], "the two imports rank alike"
    floor = _batch_write_floor(server, "imported_bulk")
    floor_name = "BatchWriteItem of the board's own items the bulk import ends with, 25 a call"
    for way, name in (("bulk", "in bulk"), ("replay", "one by one (the import route's replay)")):
        seconds, calls = runs[way]
        report.add(f"import {label} {name}", seconds, "s", floor=floor[0], floor_name=floor_name,
                   note=f"{sum(calls.values()) / len(items):.1f} requests a racer ("
                        + ", ".join(f"{n:,} {op}" for op, n in calls.most_common()) + ")"
                        + (f"; the floor wrote {floor[1]:,} items" if way == "bulk" else ""))


def _batch_write_floor(server: DynamoDbLocal, board_id: str) -> tuple[float, int]:
    """The seconds BatchWriteItem takes to write a copy of the board's items (under another
    board id), read beforehand; and how many."""
    client = server.client()
    items: list[dict[str, Any]] = []
    request: dict[str, Any] = {"TableName": TABLE, "KeyConditionExpression": "board = :b",
                               "ExpressionAttributeValues": {":b": {"S": board_id}}}
    while True:
        page = client.query(**request)
        items += [item | {"board": {"S": f"{board_id}_floor"}} for item in page["Items"]]
        if "LastEvaluatedKey" not in page:
            break
        request["ExclusiveStartKey"] = page["LastEvaluatedKey"]
    start = time.perf_counter()
    for first in range(0, len(items), 25):
        pending: Any = {TABLE: [{"PutRequest": {"Item": item}} for item in items[first:first + 25]]}
        while pending:
            pending = client.batch_write_item(RequestItems=pending).get("UnprocessedItems") or None
    return time.perf_counter() - start, len(items)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="boards of 1,000 and 10,000 racers")
    parser.add_argument("--sizes", type=int, nargs=2, metavar=("SMALL", "LARGE"))
    parser.add_argument("--reps", type=int, default=200, help="timed calls per figure (200)")
    parser.add_argument("--warmup", type=int, default=100, help="untimed pages per size first (100)")
    parser.add_argument("--count-reps", type=int, default=50, help="timed ranks and racer views (50)")
    parser.add_argument("--pushes", type=int, default=30, help="timed mid-board pushes per size (30)")
    parser.add_argument("--pushers", type=int, default=16, help="threads pushing at once (16)")
    parser.add_argument("--pushes-each", type=int, default=10, help="pushes per thread (10)")
    parser.add_argument("--import-racers", type=int,
                        help="racers imported in bulk and one by one (2000; --quick: 300)")
    parser.add_argument("--only-import", action="store_true", help="the import only")
    parser.add_argument("--only-ranks", action="store_true", help="ranks and contention only")
    parser.add_argument("--only-contention", action="store_true", help="pushes contending only")
    parser.add_argument("--threads", type=int, default=8, help="seeding threads (8)")
    parser.add_argument("--seed", type=int, default=20250301)
    parser.add_argument("--json", type=Path, help="also save the figures here")
    args = parser.parse_args(argv)
    args.sizes = args.sizes or ([1_000, 10_000] if args.quick else [1_000, 100_000])
    args.import_racers = args.import_racers or (300 if args.quick else 2_000)
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
