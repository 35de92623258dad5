#!/usr/bin/env python3
"""How fast the `drboard` command starts, against Python starting with click and rich alone.

Not a test: it runs each command many times, each in a fresh process, and prints one table of
p50 times and their ratio to the floor (`python -c "import click, rich"`), each beside its
target (PASS/FAIL). See bench/README.md.

    python bench/bench_cli.py              # 30 runs of each command: ~30 seconds
    python bench/bench_cli.py --runs 10    # a quicker look
    python bench/bench_cli.py --json figures.json

Standard library only, plus an installed drboard.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from figures import Report, drboard_command, p50_p95

START_RATIO_MAX = 1.5
FLOOR = "python -c 'import click, rich'"


@dataclass(frozen=True)
class Case:
    name: str
    argv: list[str]
    exit_code: int = 0
    target: bool = True  # held to START_RATIO_MAX, else shown for information


def cases(drboard: list[str]) -> list[Case]:
    return [
        Case(FLOOR, [sys.executable, "-c", "import click, rich"], target=False),
        Case("drboard --help", [*drboard, "--help"]),
        Case("drboard --version", [*drboard, "--version"]),
        Case("drboard pull --help", [*drboard, "pull", "--help"]),
        Case("drboard push --help", [*drboard, "push", "--help"]),
        # A fresh board file has no board yet: the pull opens it, asks, and answers "no board".
        Case("drboard pull --track reInvent2019 (empty local board)",
             [*drboard, "pull", "--track", "reInvent2019"], exit_code=1, target=False),
    ]


def isolated_env(scratch: Path) -> dict[str, str]:
    """No saved settings or endpoint of this machine: every command uses a new embedded board."""
    env = dict(os.environ, XDG_DATA_HOME=str(scratch / "data"), XDG_CONFIG_HOME=str(scratch / "config"),
               DRBOARD_DB=str(scratch / "board.db"), COLUMNS="100")
    for variable in ("DRBOARD_ENDPOINT", "DRBOARD_RACER", "PYTHONPROFILEIMPORTTIME",
                     "PYTHONDONTWRITEBYTECODE"):
        env.pop(variable, None)
    return env


def run_once(case: Case, env: dict[str, str]) -> float:
    start = time.perf_counter()
    done = subprocess.run(case.argv, env=env, capture_output=True, check=False)
    elapsed_ms = (time.perf_counter() - start) * 1000
    if done.returncode != case.exit_code:
        raise SystemExit(f"{case.name} exited {done.returncode}, not {case.exit_code}:\n"
                         + done.stderr.decode(errors="replace"))
    return elapsed_ms


def measure(all_cases: list[Case], runs: int, warmup: int, env: dict[str, str]) -> dict[str, list[float]]:
    """Round after round, every case once, so that the machine's drift falls on all alike."""
    samples: dict[str, list[float]] = {case.name: [] for case in all_cases}
    for round_ in range(warmup + runs):
        for case in all_cases:
            elapsed_ms = run_once(case, env)
            if round_ >= warmup:
                samples[case.name].append(elapsed_ms)
        if round_ >= warmup:
            print(f"  round {round_ - warmup + 1} of {runs}", file=sys.stderr, flush=True)
    return samples


def report_figures(report: Report, all_cases: list[Case], samples: dict[str, list[float]]) -> None:
    floor_p50 = p50_p95(samples[FLOOR])[0]
    report.add(f"`{FLOOR}` p50 (the floor)", floor_p50, "ms")
    for case in all_cases[1:]:
        p50, p95 = p50_p95(samples[case.name])
        report.add(f"`{case.name}` p50", p50, "ms", note=f"p95 {p95:,.0f} ms")
        ratio = p50 / floor_p50
        if case.target:
            report.add(f"`{case.name}` p50 / floor", ratio, "x", limit=START_RATIO_MAX)
        else:
            report.add(f"`{case.name}` p50 / floor", ratio, "x",
                       note="no target: it imports the service and its models to answer")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=30, help="timed runs of each command (default 30)")
    parser.add_argument("--warmup", type=int, default=2,
                        help="untimed rounds first, so the OS caches the files and .pyc (default 2)")
    parser.add_argument("--drboard", metavar="PATH",
                        help="the drboard executable (default: the one beside this Python)")
    parser.add_argument("--json", metavar="FILE", type=Path, help="also save the figures here")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    all_cases = cases(drboard_command(args.drboard))
    report = Report(config={
        "runs": args.runs, "warmup": args.warmup, "python": sys.version.split()[0],
        "platform": platform.platform(), "cpus": os.cpu_count(),
        "started_at": datetime.now(UTC).isoformat(timespec="seconds"),
    })
    with tempfile.TemporaryDirectory(prefix="drboard-bench-cli-") as scratch:
        samples = measure(all_cases, args.runs, args.warmup, isolated_env(Path(scratch)))
    report_figures(report, all_cases, samples)
    config = report.config
    report.print_summary(f"drboard start-up benchmark · Python {config['python']} · "
                         f"{config['platform']} · {config['cpus']} CPUs · {args.runs} runs each",
                         args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
