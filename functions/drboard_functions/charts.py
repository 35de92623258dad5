"""Small SVG charts for the web pages: bars, points and lines, drawn on the server (no script).

Each chart is a ``<figure>`` whose SVG has a ``<title>`` and whose caption says in words what it
shows, for screen readers; labels go through :func:`html.escape`.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from html import escape

WIDTH, HEIGHT, PAD = 640, 280, 44
LEFT = 76  # room for the y axis's tick labels (e.g. "100.873")
INSET = 12  # points at the ends of a range stay clear of the axes
AXIS, GRID, MARK, HIGHLIGHT, DIM = "#9aa7b4", "#26313d", "#7cc4ff", "#ffd24d", "#5b6773"


@dataclass(frozen=True)
class Bar:
    label: str
    value: float
    text: str
    strong: bool = True


@dataclass(frozen=True)
class Point:
    x: float
    y: float
    label: str
    strong: bool = False


def bars(title: str, caption: str, items: Sequence[Bar], unit: str) -> str:
    """Vertical bars from zero; weak bars (e.g. unfinished laps) are drawn dim."""
    top = max((b.value for b in items), default=1) or 1
    width = (WIDTH - LEFT - PAD) / max(1, len(items))
    shapes = []
    for index, bar in enumerate(items):
        height = (HEIGHT - 2 * PAD) * bar.value / top
        x = LEFT + index * width
        y = HEIGHT - PAD - height
        shapes.append(
            f'<rect x="{x + width * .15:.1f}" y="{y:.1f}" width="{width * .7:.1f}" '
            f'height="{height:.1f}" fill="{MARK if bar.strong else DIM}"><title>'
            f"{escape(bar.label)}: {escape(bar.text)}</title></rect>"
            f'<text x="{x + width / 2:.1f}" y="{HEIGHT - PAD + 16}" text-anchor="middle">'
            f"{escape(bar.label)}</text>"
            f'<text x="{x + width / 2:.1f}" y="{y - 6:.1f}" text-anchor="middle">'
            f"{escape(bar.text)}</text>")
    return _figure(title, caption, _axes(unit, "") + "".join(shapes))


def points(title: str, caption: str, items: Sequence[Point], x_label: str, y_label: str,
           x_range: tuple[float, float] | None = None,
           y_range: tuple[float, float] | None = None, area: tuple[float, float, float, float]
           | None = None) -> str:
    """A scatter of points (strong ones highlighted), optionally over a shaded ``area``
    (x0, x1, y0, y1), e.g. a continuous action space."""
    xs = [p.x for p in items] + ([area[0], area[1]] if area else [])
    ys = [p.y for p in items] + ([area[2], area[3]] if area else [])
    x0, x1 = x_range or (min(xs, default=0), max(xs, default=1))
    y0, y1 = y_range or (min(ys, default=0), max(ys, default=1))
    sx = _scale(x0, x1, LEFT + INSET, WIDTH - PAD - INSET)
    sy = _scale(y0, y1, HEIGHT - PAD - INSET, PAD + INSET)
    shapes = []
    if area:
        left, right = sorted((sx(area[0]), sx(area[1])))
        bottom, top = sorted((sy(area[2]), sy(area[3])))
        shapes.append(f'<rect x="{left:.1f}" y="{bottom:.1f}" width="{right - left:.1f}" '
                      f'height="{top - bottom:.1f}" fill="{MARK}" fill-opacity=".35"/>')
    for point in items:
        colour = HIGHLIGHT if point.strong else MARK
        shapes.append(f'<circle cx="{sx(point.x):.1f}" cy="{sy(point.y):.1f}" r="6" '
                      f'fill="{colour}"><title>{escape(point.label)}</title></circle>')
    ticks = (f'<text x="{sx(x0):.1f}" y="{HEIGHT - PAD + 16}" text-anchor="middle">{x0:g}</text>'
             f'<text x="{sx(x1):.1f}" y="{HEIGHT - PAD + 16}" text-anchor="middle">{x1:g}</text>'
             f'<text x="{LEFT - 6}" y="{sy(y0) + 4:.1f}" text-anchor="end">{y0:g}</text>'
             f'<text x="{LEFT - 6}" y="{sy(y1) + 4:.1f}" text-anchor="end">{y1:g}</text>')
    return _figure(title, caption, _axes(y_label, x_label) + ticks + "".join(shapes))


def line(title: str, caption: str, values: Sequence[tuple[float, float]], x_label: str,
         y_label: str) -> str:
    """One line through (x, y) values, in order."""
    if not values:
        return ""
    xs, ys = [x for x, _ in values], [y for _, y in values]
    sx = _scale(min(xs), max(xs), LEFT, WIDTH - PAD)
    sy = _scale(min(ys), max(ys), HEIGHT - PAD, PAD)
    path = " ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in values)
    ticks = (f'<text x="{LEFT - 6}" y="{HEIGHT - PAD}" text-anchor="end">{min(ys):g}</text>'
             f'<text x="{LEFT - 6}" y="{PAD + 4}" text-anchor="end">{max(ys):g}</text>'
             f'<text x="{WIDTH - PAD}" y="{HEIGHT - PAD + 16}" text-anchor="middle">{max(xs):g}</text>')
    return _figure(title, caption, _axes(y_label, x_label) + ticks +
                   f'<polyline points="{path}" fill="none" stroke="{MARK}" stroke-width="2.5"/>')


def _scale(low: float, high: float, start: float, end: float) -> Callable[[float], float]:
    span = (high - low) or 1.0
    return lambda value: start + (value - low) / span * (end - start)


def _axes(y_label: str, x_label: str) -> str:
    return (f'<line x1="{LEFT}" y1="{HEIGHT - PAD}" x2="{WIDTH - PAD}" y2="{HEIGHT - PAD}" '
            f'stroke="{GRID}"/><line x1="{LEFT}" y1="{PAD}" x2="{LEFT}" y2="{HEIGHT - PAD}" '
            f'stroke="{GRID}"/>'
            f'<text x="{LEFT}" y="{PAD - 14}">{escape(y_label)}</text>'
            f'<text x="{WIDTH - PAD}" y="{HEIGHT - 6}" text-anchor="end">{escape(x_label)}</text>')


def _figure(title: str, caption: str, body: str) -> str:
    ident = "chart-" + hashlib.sha1(title.encode(), usedforsecurity=False).hexdigest()[:8]
    return (f'<figure class="chart"><svg viewBox="0 0 {WIDTH} {HEIGHT}" role="img" '
            f'aria-labelledby="{ident}" font-size="13" fill="{AXIS}">'
            f'<title id="{ident}">{escape(title)}</title>{body}</svg>'
            f"<figcaption>{escape(caption)}</figcaption></figure>")
