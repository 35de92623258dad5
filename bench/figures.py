"""The figures table every benchmark prints: value, its floor and ratio (when it has one),
target, PASS/FAIL, and notes."""

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
    #: The same figure for the fastest honest program giving the same output, in the same unit.
    floor: float | None = None
    floor_name: str = ""

    @property
    def ratio(self) -> float | None:
        if self.value is None or not self.floor:
            return None
        return self.value / self.floor

    def shown(self, value: float | None = None, unit: str | None = None) -> str:
        value = self.value if value is None and unit is None else value
        unit = self.unit if unit is None else unit
        if value is None:
            return "n/a"
        if unit == "ms":
            return f"{value:,.2f} ms" if value < 100 else f"{value:,.0f} ms"
        if unit == "s":
            return f"{value:,.2f} s"
        if unit == "x":
            return f"{value:,.2f} x"
        if unit == "MiB":
            return f"{value:,.1f} MiB"
        if unit == "us":
            return f"{value:,.1f} us"
        return f"{value:,.0f} {unit}".strip()


@dataclass
class Report:
    figures: list[Figure] = field(default_factory=list)
    config: dict[str, Any] = field(default_factory=dict)

    def add(self, name: str, value: float | None, unit: str, *, limit: float | None = None,
            ok: bool | None = None, target: str = "", note: str = "", floor: float | None = None,
            floor_name: str = "", ratio_limit: float | None = None) -> Figure:
        """A figure; with ``limit`` (or an ``ok`` verdict) it is checked against a target. With
        a ``floor`` (what ``floor_name`` takes for the same output), its ratio to the floor is
        shown beside it, and checked against ``ratio_limit`` when given."""
        if limit is not None:
            ok = value is not None and value <= limit
            target = target or f"<= {Figure('', limit, unit).shown()}"
        figure = Figure(name, value, unit, target, ok, note, floor, floor_name)
        if ratio_limit is not None:
            figure.ok = figure.ratio is not None and figure.ratio <= ratio_limit and ok is not False
            figure.target = f"{target + ', ' if target else ''}<= {ratio_limit:g} x the floor"
        self.figures.append(figure)
        floored = (f" (floor {figure.shown(floor, unit)}, {figure.shown(figure.ratio, 'x')})"
                   if floor is not None else "")
        print(f"  {name}: {figure.shown()}{floored}"
              + (f"  [{_verdict(figure.ok)}]" if figure.ok is not None else ""),
              file=sys.stderr, flush=True)
        return figure

    def table(self) -> str:
        floors = any(f.floor is not None for f in self.figures)
        # Each floor's program is described once, under a letter its figures' floors carry.
        keys: dict[str, str] = {}
        for f in self.figures:
            if f.floor is not None and f.floor_name and f.floor_name not in keys:
                keys[f.floor_name] = _letters(len(keys))
        rows = [("Figure", "Value", "Floor", "Ratio", "Target", "Result") if floors
                else ("Figure", "Value", "Target", "Result")]
        for f in self.figures:
            key = f" ({keys[f.floor_name]})" if f.floor_name in keys else ""
            floor = ((f.shown(f.floor, f.unit) + key, f.shown(f.ratio, "x")) if f.floor is not None
                     else ("-", "-"))
            rows.append((f.name, f.shown(), *(floor if floors else ()), f.target or "-", _verdict(f.ok)))
        columns = len(rows[0])
        widths = [max(len(row[i]) for row in rows) for i in range(columns)]
        right = {1, 2, 3} if floors else {1}
        lines = []
        for index, row in enumerate(rows):
            cells = [f"{cell:>{widths[i]}}" if i in right else f"{cell:<{widths[i]}}"
                     for i, cell in enumerate(row)]
            lines.append("  ".join(cells).rstrip())
            if index == 0:
                lines.append("  ".join("-" * w for w in widths))
        if keys:
            lines += ["", "Floors (the fastest honest program for the same output):",
                      *(f"  ({key}) {name}" for name, key in keys.items())]
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


def _letters(index: int) -> str:
    """a, b, ..., z, aa, ab, ...: the key of the index-th floor."""
    return (_letters(index // 26 - 1) if index >= 26 else "") + chr(ord("a") + index % 26)


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
