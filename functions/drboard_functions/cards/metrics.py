"""Text on a card, measured with the card font's own advance widths (``fonts/widths.json``,
written from the fonts by :mod:`.widths`), and fitted to its box.

A name too wide for its box is drawn smaller, down to a least size, and past that cut with an
ellipsis. Kerning is left out of the measure: it only brings letters closer, so a measured text
never comes out wider than drawn.

Liberation Sans covers the Latin, Greek and Cyrillic scripts (and Hebrew). A character it lacks
(Chinese, Japanese, Korean, Arabic, Indic scripts, emoji, …) is drawn in the PNG as the font's
missing-glyph box, and measured as one; in the SVG such a text is held to its measured width
(``textLength``), so a viewer that has a font for it still keeps it inside its box.
"""

from __future__ import annotations

import json
import unicodedata
from dataclasses import dataclass
from functools import cache
from importlib.resources import files
from typing import Literal

Face = Literal["regular", "bold"]
#: The card font's faces, in ``fonts/`` beside their licence (SIL Open Font License 1.1).
FACES: dict[Face, str] = {"regular": "LiberationSans-Regular.ttf", "bold": "LiberationSans-Bold.ttf"}
FAMILY = "Liberation Sans"
ELLIPSIS = "…"


@dataclass(frozen=True)
class Fitted:
    """A text as drawn: maybe cut short, at a size (px); ``width`` is its measured width, and
    ``covered`` whether the font has every character of it."""

    text: str
    size: float
    width: float
    covered: bool


@dataclass(frozen=True)
class _Widths:
    units_per_em: int
    missing: int
    advances: dict[int, int]


@cache
def _widths(face: Face) -> _Widths:
    table = json.loads((files("drboard_functions.cards") / "fonts" / "widths.json").read_text("utf-8"))
    data = table["faces"][face]
    advances = {start + offset: width for start, run in data["runs"] for offset, width in enumerate(run)}
    return _Widths(table["units_per_em"], data["missing"], advances)


def covers(text: str, face: Face = "regular") -> bool:
    """Whether the font draws every character of ``text`` (none as a missing-glyph box)."""
    advances = _widths(face).advances
    return all(ord(char) in advances or _invisible(char) for char in text)


def width(text: str, size: float, face: Face = "regular") -> float:
    """How wide ``text`` is drawn at ``size`` px."""
    widths = _widths(face)
    units = sum(widths.advances.get(ord(char), 0 if _invisible(char) else widths.missing) for char in text)
    return units * size / widths.units_per_em


def fit(text: str, box: float, size: float, least: float, face: Face = "regular") -> Fitted:
    """``text`` at ``size`` px if it fits ``box`` px; else smaller, down to ``least`` px; else
    at ``least`` px, cut with an ellipsis to fit."""
    text = " ".join(text.split())
    measured = width(text, size, face)
    if measured > box:
        size = max(least, int(size * box / measured))
        measured = width(text, size, face)
    if measured > box:
        while text and width(text.rstrip() + ELLIPSIS, size, face) > box:
            text = text[:-1]
        text = text.rstrip() + ELLIPSIS
        measured = width(text, size, face)
    return Fitted(text, size, measured, covers(text, face))


def _invisible(char: str) -> bool:
    """A combining mark or a format character: drawn on or with its neighbour, taking no advance
    of its own when the font lacks it."""
    return unicodedata.category(char) in ("Mn", "Me", "Cf")
