"""Small SVG charts for the web pages: bars, points and lines, laid out here and drawn by the
``chart`` macro of ``templates/macros.html`` (no script).

Each chart is a figure whose SVG has a title and whose caption says in words what it shows, for
screen readers; the template escapes every label.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

WIDTH, HEIGHT, PAD = 640, 280, 44
LEFT = 76  # room for the y axis's tick labels (e.g. "100.873")
INSET = 12  # points at the ends of a range stay clear of the axes
AXIS, GRID, MARK, HIGHLIGHT, DIM = "#9aa7b4", "#26313d", "#7cc4ff", "#ffd24d", "#5b6773"
#: One colour and one marker shape per racer on a chart of several (the legend's order).
SERIES = (("#7cc4ff", "circle"), ("#ffd24d", "square"), ("#f0a868", "circle"), ("#b4e380", "square"))


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


@dataclass(frozen=True)
class Series:
    """One racer's line on a chart of several: (x, y or None for a gap, label) points."""

    name: str
    points: Sequence[tuple[float, float | None, str]]


@dataclass(frozen=True)
class Line:
    x1: str
    y1: str
    x2: str
    y2: str
    colour: str = GRID


@dataclass(frozen=True)
class Area:
    x: str
    y: str
    width: str
    height: str
    colour: str
    opacity: str = "1"
    label: str = ""


@dataclass(frozen=True)
class Path:
    points: str
    colour: str
    dashed: bool = False


@dataclass(frozen=True)
class Dot:
    x: float
    y: float
    colour: str
    label: str
    shape: str = "circle"
    hollow: bool = False


@dataclass(frozen=True)
class Text:
    x: str
    y: str
    text: str
    anchor: str = ""


@dataclass
class Figure:
    """What the template draws: shapes in SVG units, a title and a caption."""

    title: str
    caption: str
    width: int = WIDTH
    height: int = HEIGHT
    axis_colour: str = AXIS
    lines: list[Line] = field(default_factory=list)
    areas: list[Area] = field(default_factory=list)
    paths: list[Path] = field(default_factory=list)
    dots: list[Dot] = field(default_factory=list)
    texts: list[Text] = field(default_factory=list)
    legend: list[str] = field(default_factory=list)

    @property
    def ident(self) -> str:
        return "chart-" + hashlib.sha1(self.title.encode(), usedforsecurity=False).hexdigest()[:8]


def _n(value: float) -> str:
    return f"{value:.1f}"


def bars(title: str, caption: str, items: Sequence[Bar], unit: str) -> Figure:
    """Vertical bars from zero; weak bars (e.g. unfinished laps) are drawn dim."""
    figure = _axes(Figure(title, caption), unit, "")
    top = max((b.value for b in items), default=1) or 1
    width = (WIDTH - LEFT - PAD) / max(1, len(items))
    for index, bar in enumerate(items):
        height = (HEIGHT - 2 * PAD) * bar.value / top
        x = LEFT + index * width
        y = HEIGHT - PAD - height
        figure.areas.append(Area(_n(x + width * .15), _n(y), _n(width * .7), _n(height),
                                 MARK if bar.strong else DIM, label=f"{bar.label}: {bar.text}"))
        figure.texts.append(Text(_n(x + width / 2), str(HEIGHT - PAD + 16), bar.label, "middle"))
        figure.texts.append(Text(_n(x + width / 2), _n(y - 6), bar.text, "middle"))
    return figure


def points(title: str, caption: str, items: Sequence[Point], x_label: str, y_label: str,
           x_range: tuple[float, float] | None = None,
           y_range: tuple[float, float] | None = None, area: tuple[float, float, float, float]
           | None = None) -> Figure:
    """A scatter of points (strong ones highlighted), optionally over a shaded ``area``
    (x0, x1, y0, y1), e.g. a continuous action space."""
    figure = _axes(Figure(title, caption), y_label, x_label)
    xs = [p.x for p in items] + ([area[0], area[1]] if area else [])
    ys = [p.y for p in items] + ([area[2], area[3]] if area else [])
    x0, x1 = x_range or (min(xs, default=0), max(xs, default=1))
    y0, y1 = y_range or (min(ys, default=0), max(ys, default=1))
    sx = _scale(x0, x1, LEFT + INSET, WIDTH - PAD - INSET)
    sy = _scale(y0, y1, HEIGHT - PAD - INSET, PAD + INSET)
    if area:
        left, right = sorted((sx(area[0]), sx(area[1])))
        bottom, top = sorted((sy(area[2]), sy(area[3])))
        figure.areas.append(Area(_n(left), _n(bottom), _n(right - left), _n(top - bottom), MARK,
                                 opacity=".35"))
    figure.dots.extend(Dot(round(sx(p.x), 1), round(sy(p.y), 1), HIGHLIGHT if p.strong else MARK,
                           p.label) for p in items)
    figure.texts += _ticks(sx, sy, x0, x1, y0, y1)
    return figure


def line(title: str, caption: str, values: Sequence[tuple[float, float]], x_label: str,
         y_label: str) -> Figure | None:
    """One line through (x, y) values, in order; None when there are none."""
    if not values:
        return None
    figure = _axes(Figure(title, caption), y_label, x_label)
    xs, ys = [x for x, _ in values], [y for _, y in values]
    sx = _scale(min(xs), max(xs), LEFT, WIDTH - PAD)
    sy = _scale(min(ys), max(ys), HEIGHT - PAD, PAD)
    figure.paths.append(Path(" ".join(f"{sx(x):.1f},{sy(y):.1f}" for x, y in values), MARK))
    figure.texts += [Text(str(LEFT - 6), str(HEIGHT - PAD), f"{min(ys):g}", "end"),
                     Text(str(LEFT - 6), str(PAD + 4), f"{max(ys):g}", "end"),
                     Text(str(WIDTH - PAD), str(HEIGHT - PAD + 16), f"{max(xs):g}", "middle")]
    return figure


def lines(title: str, caption: str, series: Sequence[Series], x_label: str,
          y_label: str) -> Figure:
    """Several racers' lines over the same x (e.g. lap times lap by lap), each in its colour
    and marker shape, with a legend; a None y is a gap (an unfinished lap)."""
    figure = _axes(Figure(title, caption, legend=[s.name for s in series]), y_label, x_label)
    xs = [x for s in series for x, _, _ in s.points]
    ys = [y for s in series for _, y, _ in s.points if y is not None]
    if not xs or not ys:
        return figure
    low, high = min(ys), max(ys)
    margin = (high - low) * .1 or .5
    y0, y1 = max(0.0, low - margin), high + margin
    sx = _scale(min(xs), max(xs), LEFT + INSET, WIDTH - PAD - INSET)
    sy = _scale(y0, y1, HEIGHT - PAD - INSET, PAD + INSET)
    for index, one in enumerate(series):
        colour, shape = SERIES[index % len(SERIES)]
        stretch: list[str] = []
        for x, y, label in [*one.points, (0.0, None, "")]:
            if y is None:
                if len(stretch) > 1:
                    figure.paths.append(Path(" ".join(stretch), colour, dashed=index % 2 == 1))
                stretch = []
                continue
            stretch.append(f"{sx(x):.1f},{sy(y):.1f}")
            figure.dots.append(Dot(round(sx(x), 1), round(sy(y), 1), colour, label, shape))
    figure.texts += _ticks(sx, sy, min(xs), max(xs), y0, y1, y_format="{:.2f}")
    return figure


def _ticks(sx: Callable[[float], float], sy: Callable[[float], float], x0: float, x1: float,
           y0: float, y1: float, y_format: str = "{:g}") -> list[Text]:
    return [Text(_n(sx(x0)), str(HEIGHT - PAD + 16), f"{x0:g}", "middle"),
            Text(_n(sx(x1)), str(HEIGHT - PAD + 16), f"{x1:g}", "middle"),
            Text(str(LEFT - 6), _n(sy(y0) + 4), y_format.format(y0), "end"),
            Text(str(LEFT - 6), _n(sy(y1) + 4), y_format.format(y1), "end")]


def _scale(low: float, high: float, start: float, end: float) -> Callable[[float], float]:
    span = (high - low) or 1.0
    return lambda value: start + (value - low) / span * (end - start)


def _axes(figure: Figure, y_label: str, x_label: str) -> Figure:
    figure.lines += [Line(str(LEFT), str(HEIGHT - PAD), str(WIDTH - PAD), str(HEIGHT - PAD)),
                     Line(str(LEFT), str(PAD), str(LEFT), str(HEIGHT - PAD))]
    figure.texts += [Text(str(LEFT), str(PAD - 14), y_label),
                     Text(str(WIDTH - PAD), str(HEIGHT - 6), x_label, "end")]
    return figure
