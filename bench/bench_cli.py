#!/usr/bin/env python3
"""How fast the `drboard` command starts and answers, against the floors under it: Python
starting with click and rich alone, and for a real `drboard pull`, a click + rich + sqlite3
program that prints the same bytes from the same board (bench/pull_floor.py).

A real pull is timed twice: as a pull answers when the board's standings are kept beside the
embedded board for the board as it is (after a pull, or a `drboard push`, of it), and as the
first pull after a change something else made (a push to `drboard serve`, an organiser's
command), which reads the board through the service: the kept standings are dropped, untimed,
before each of its runs. Both print the floor's bytes (checked).

Not a test: it runs each command many times, each in a fresh process, and prints one table of
p50 times and their ratio to their floor, each beside its target (PASS/FAIL). See bench/README.md.

    python bench/bench_cli.py              # 30 runs of each command: ~1 minute
    python bench/bench_cli.py --runs 10    # a quicker look
    python bench/bench_cli.py --json figures.json

Standard library only, plus an installed drboard (whose dependencies bring click and rich).
"""

from __future__ import annotations

import argparse
import os
import platform
import sqlite3
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from figures import Report, drboard_command, p50_p95

START_RATIO_MAX = 1.5
PULL_RATIO_MAX = 1.5
FLOOR = "python -c 'import click, rich'"
PULL_FLOOR = "bench/pull_floor.py"  # click + rich + sqlite3, printing the same bytes
PULL = "drboard pull --track reInvent2019"  # on a board holding the examples
PULL_CHANGED = "drboard pull --track reInvent2019 (through the service)"
ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted(p for p in (ROOT / "examples").iterdir() if p.is_dir())


@dataclass(frozen=True)
class Case:
    name: str
    argv: list[str]
    exit_code: int = 0
    floor: str | None = FLOOR  # the case it is held to (None: it is a floor)
    limit: float | None = START_RATIO_MAX
    before: Callable[[], None] | None = None  # done before each run, untimed


def cases(drboard: list[str], board: Path) -> list[Case]:
    return [
        Case(FLOOR, [sys.executable, "-c", "import click, rich"], floor=None),
        Case(PULL_FLOOR, [sys.executable, str(ROOT / "bench" / "pull_floor.py"), "--db", str(board),
                          "--board", "reInvent2019_track"], floor=None),
        Case("drboard --help", [*drboard, "--help"]),
        Case("drboard --version", [*drboard, "--version"]),
        Case("drboard pull --help", [*drboard, "pull", "--help"]),
        Case("drboard push --help", [*drboard, "push", "--help"]),
        Case(PULL, [*drboard, "pull", "--track", "reInvent2019"], floor=PULL_FLOOR, limit=PULL_RATIO_MAX),
        Case(PULL_CHANGED, [*drboard, "pull", "--track", "reInvent2019"], floor=PULL_FLOOR, limit=None,
             before=lambda: forget_kept_standings(board)),
    ]


def forget_kept_standings(board: Path) -> None:
    """As after a push: no standings kept for the board as it is, so the pull reads it."""
    with sqlite3.connect(board) as db:
        if db.execute("SELECT 1 FROM sqlite_master WHERE name = 'kept_standings'").fetchone():
            db.execute("DELETE FROM kept_standings")


def isolated_env(scratch: Path) -> dict[str, str]:
    """No saved settings or endpoint of this machine: every command uses the scratch board."""
    env = dict(os.environ, XDG_DATA_HOME=str(scratch / "data"), XDG_CONFIG_HOME=str(scratch / "config"),
               DRBOARD_DB=str(scratch / "board.db"), COLUMNS="100")
    for variable in ("DRBOARD_ENDPOINT", "DRBOARD_RACER", "PYTHONPROFILEIMPORTTIME",
                     "PYTHONDONTWRITEBYTECODE"):
        env.pop(variable, None)
    return env


def board_with_examples(drboard: list[str], env: dict[str, str]) -> Path:
    """The scratch board (DRBOARD_DB), with every example run pushed to it."""
    done = subprocess.run([*drboard, "push", *map(str, EXAMPLES)], env=env, capture_output=True, check=False)
    if done.returncode:
        raise SystemExit("pushing the examples failed:\n" + done.stderr.decode(errors="replace"))
    return Path(env["DRBOARD_DB"])


def check_same_bytes(all_cases: list[Case], env: dict[str, str]) -> None:
    """The real pulls and their floor print the same bytes (else the floor measures something
    else); the pull after a change first, as it keeps the standings the other one prints."""
    printed = {}
    for case in sorted(all_cases, key=lambda case: case.name != PULL_CHANGED):
        if case.floor == PULL_FLOOR or case.name == PULL_FLOOR:
            if case.before:
                case.before()
            printed[case.name] = subprocess.run(case.argv, env=env, capture_output=True, check=True).stdout
    for name in (PULL_CHANGED, PULL):
        if printed[name] != printed[PULL_FLOOR] or b"Blaze" not in printed[name]:
            raise SystemExit(f"the pull floor does not print what {name} prints:\n"
                             + printed[name].decode() + "\n" + printed[PULL_FLOOR].decode())


def run_once(case: Case, env: dict[str, str]) -> float:
    if case.before:
        case.before()
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
    p50s = {name: p50_p95(times)[0] for name, times in samples.items()}
    for case in all_cases:
        p50, p95 = p50_p95(samples[case.name])
        if case.floor is None:
            report.add(f"`{case.name}` p50 (a floor)", p50, "ms", note=f"p95 {p95:,.0f} ms")
            continue
        report.add(f"`{case.name}` p50", p50, "ms", note=f"p95 {p95:,.0f} ms")
        report.add(f"`{case.name}` p50 / `{case.floor}`", p50 / p50s[case.floor], "x", limit=case.limit,
                   note="" if case.limit else "no target: no standings kept for the board as it "
                                                "is (changed by something else)")
        if case.floor != FLOOR:
            report.add(f"`{case.name}` p50 / `{FLOOR}`", p50 / p50s[FLOOR], "x",
                       note="no target: the pull also reads the board and prints the standings")


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
    drboard = drboard_command(args.drboard)
    report = Report(config={
        "runs": args.runs, "warmup": args.warmup, "python": sys.version.split()[0],
        "platform": platform.platform(), "cpus": os.cpu_count(),
        "started_at": datetime.now(UTC).isoformat(timespec="seconds"),
    })
    with tempfile.TemporaryDirectory(prefix="drboard-bench-cli-") as scratch:
        env = isolated_env(Path(scratch))
        all_cases = cases(drboard, board_with_examples(drboard, env))
        check_same_bytes(all_cases, env)
        samples = measure(all_cases, args.runs, args.warmup, env)
    report_figures(report, all_cases, samples)
    config = report.config
    report.print_summary(f"drboard start-up benchmark · Python {config['python']} · "
                         f"{config['platform']} · {config['cpus']} CPUs · {args.runs} runs each",
                         args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
