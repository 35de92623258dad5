#!/usr/bin/env python3
"""Fuzz the assembler: thousands of seeded mutations of the example runs, each assembled in a
worker process under a time and a memory bound. Prints how many became a record, how many ended
in one clean error, and every traceback, hang or memory blow-up with the seed that repeats it.

    python bench/fuzz_assembler.py                      # 2,000 cases from seed 0
    python bench/fuzz_assembler.py --runs 10000 --seed 50000 --seconds 5 --memory-mib 512
    python bench/fuzz_assembler.py --runs 1 --seed 1234 # repeat one case

Exits 1 when any case is neither a record nor a clean error. The mutations are in
tests/fuzzkit.py; tests/unit/test_fuzz_assembler.py runs a small budget of them in the suite.
"""

from __future__ import annotations

import argparse
import os
import resource
import signal
import sys
import tempfile
import time
import traceback
import tracemalloc
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from drboard_assembler import AssemblyError, assemble  # noqa: E402

from tests.fuzzkit import mutate  # noqa: E402


class Outcome(NamedTuple):
    seed: int
    kind: str  # record | error | traceback | hang | memory
    seconds: float
    peak_bytes: int
    detail: str


class _Hang(Exception):
    pass


def _on_alarm(signum: int, frame: object) -> None:
    raise _Hang


def _bound_memory(memory_mib: int) -> None:
    limit = memory_mib * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    signal.signal(signal.SIGALRM, _on_alarm)


def run_case(seed: int, seconds: float) -> Outcome:
    with tempfile.TemporaryDirectory(prefix="drboard-fuzz-") as scratch:
        path = mutate(seed, Path(scratch))
        tracemalloc.start()
        started = time.perf_counter()
        signal.setitimer(signal.ITIMER_REAL, seconds)
        try:
            record = assemble(path)
            kind, detail = "record", f"{record.racer} on {record.track}"
        except AssemblyError as error:
            kind, detail = "error", str(error)
        except _Hang:
            kind, detail = "hang", f"over {seconds} s"
        except MemoryError:
            kind, detail = "memory", "MemoryError"
        except Exception:  # exactly what the fuzzer looks for
            kind, detail = "traceback", traceback.format_exc()
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            elapsed = time.perf_counter() - started
            peak = tracemalloc.get_traced_memory()[1]
            tracemalloc.stop()
    return Outcome(seed, kind, elapsed, peak, detail)


def _problem(outcome: Outcome) -> str:
    first = outcome.detail.strip().splitlines()
    return first[-1] if first else outcome.kind


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=2000, help="how many cases (default 2000)")
    parser.add_argument("--seed", type=int, default=0, help="the first case's seed (default 0)")
    parser.add_argument("--seconds", type=float, default=10.0, help="time bound of one case")
    parser.add_argument("--memory-mib", type=int, default=1024, help="memory bound of a worker")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    args = parser.parse_args()

    seeds = range(args.seed, args.seed + args.runs)
    started = time.perf_counter()
    with ProcessPoolExecutor(args.workers, initializer=_bound_memory,
                             initargs=(args.memory_mib,)) as pool:
        outcomes = list(pool.map(run_case, seeds, [args.seconds] * len(seeds), chunksize=8))
    wall = time.perf_counter() - started

    kinds = Counter(o.kind for o in outcomes)
    slowest = max(outcomes, key=lambda o: o.seconds)
    hungriest = max(outcomes, key=lambda o: o.peak_bytes)
    print(f"drboard assembler fuzz: {len(outcomes)} cases, seeds {seeds.start}..{seeds.stop - 1}, "
          f"{args.workers} workers, {wall:.1f} s, Python {sys.version.split()[0]}")
    print(f"  bounds per case: {args.seconds} s, {args.memory_mib} MiB")
    for kind in ("record", "error", "traceback", "hang", "memory"):
        print(f"  {kind + ':':<11}{kinds.get(kind, 0):>7}")
    print(f"  slowest case:   {slowest.seconds:.3f} s (seed {slowest.seed})")
    print(f"  peak allocated: {hungriest.peak_bytes / 1024 / 1024:.1f} MiB (seed {hungriest.seed})")
    print("  most common errors:")
    for message, count in Counter(_problem(o).split(": ")[-1][:70] for o in outcomes
                                  if o.kind == "error").most_common(8):
        print(f"    {count:>6}  {message}")
    bad = [o for o in outcomes if o.kind not in ("record", "error")]
    for outcome in bad[:20]:
        print(f"\n--- seed {outcome.seed}: {outcome.kind}\n{outcome.detail}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
