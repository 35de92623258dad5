"""The figures table every benchmark prints: value, target, PASS/FAIL, and notes."""

from __future__ import annotations

import json
import shutil
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any


@dataclass
class Figure:
    name: str
    value: float | None
    unit: str
    target: str = ""
    ok: bool | None = None  # None: informational, no target
    note: str = ""

    def shown(self) -> str:
        if self.value is None:
            return "n/a"
        if self.unit == "ms":
            return f"{self.value:,.2f} ms" if self.value < 100 else f"{self.value:,.0f} ms"
        if self.unit == "s":
            return f"{self.value:,.2f} s"
        if self.unit == "x":
            return f"{self.value:,.2f} x"
        if self.unit == "MiB":
            return f"{self.value:,.1f} MiB"
        return f"{self.value:,.0f} {self.unit}".strip()


@dataclass
class Report:
    figures: list[Figure] = field(default_factory=list)
    config: dict[str, Any] = field(default_factory=dict)

    def add(self, name: str, value: float | None, unit: str, *, limit: float | None = None,
            ok: bool | None = None, target: str = "", note: str = "") -> Figure:
        """A figure; with ``limit`` (or an ``ok`` verdict) it is checked against a target."""
        if limit is not None:
            ok = value is not None and value <= limit
            target = target or f"<= {Figure('', limit, unit).shown()}"
        figure = Figure(name, value, unit, target, ok, note)
        self.figures.append(figure)
        print(f"  {name}: {figure.shown()}" + (f"  [{_verdict(ok)}]" if ok is not None else ""),
              file=sys.stderr, flush=True)
        return figure

    def table(self) -> str:
        rows = [("Figure", "Value", "Target", "Result")]
        for f in self.figures:
            rows.append((f.name, f.shown(), f.target or "-", _verdict(f.ok)))
        widths = [max(len(row[i]) for row in rows) for i in range(4)]
        lines = []
        for index, (name, value, target, result) in enumerate(rows):
            lines.append(f"{name:<{widths[0]}}  {value:>{widths[1]}}  {target:<{widths[2]}}  "
                         f"{result}")
            if index == 0:
                lines.append("  ".join("-" * w for w in widths))
        notes = [f"  {f.name}: {f.note}" for f in self.figures if f.note]
        if notes:
            lines += ["", "Notes:", *notes]
        return "\n".join(lines)


    def print_summary(self, title: str, json_path: Path | None = None) -> None:
        """The title, the table and the verdict on standard output; the figures also saved as
        JSON when ``json_path`` is given."""
        print()
        print(title)
        print()
        print(self.table())
        failed = [f.name for f in self.figures if f.ok is False]
        print()
        print(f"{len(failed)} of {sum(f.ok is not None for f in self.figures)} targets missed"
              if failed else "All targets met.")
        if json_path:
            json_path.write_text(json.dumps(
                {"config": self.config, "figures": [asdict(f) for f in self.figures]}, indent=2) + "\n")
            print(f"Figures saved to {json_path}")


def _verdict(ok: bool | None) -> str:
    return "-" if ok is None else "PASS" if ok else "FAIL"


def p50_p95(samples: list[float]) -> tuple[float, float]:
    """The median and the 95th percentile (inclusive method) of the samples."""
    if len(samples) == 1:
        return samples[0], samples[0]
    cuts = statistics.quantiles(samples, n=100, method="inclusive")
    return cuts[49], cuts[94]


def timed_ms(call: Callable[[], Any]) -> float:
    start = time.perf_counter()
    call()
    return (time.perf_counter() - start) * 1000


def drboard_command(explicit: str | None, fallback: list[str] | None = None) -> list[str]:
    """The `drboard` a user runs: ``explicit``, else the console script beside this Python, else
    the one on PATH, else ``fallback`` (none: stop, saying how to install it)."""
    if explicit:
        return [explicit]
    beside = Path(sys.executable).parent / "drboard"
    if beside.exists():
        return [str(beside)]
    found = shutil.which("drboard")
    if found:
        return [found]
    if fallback is None:
        raise SystemExit("no drboard command found: pip install -e . (or give --drboard PATH)")
    return fallback
