"""The PNG of a card, rendered from its SVG by resvg (the resvg-py package: one compiled module,
about 3 MB), with the card fonts and no system font, so that a card is drawn the same by the
CardFunction, `drboard serve` and the embedded board. resvg is imported on the first card a
process draws."""

from __future__ import annotations

from functools import cache
from importlib.resources import as_file, files

from .metrics import FACES


@cache
def _font_files() -> list[str]:
    fonts = files("drboard_functions.cards") / "fonts"
    paths = []
    for filename in FACES.values():
        with as_file(fonts / filename) as path:  # a real file already: the package is unzipped
            paths.append(str(path))
    return paths


def render(svg: str) -> bytes:
    """The PNG of ``svg``, at its own size."""
    import resvg_py

    return bytes(resvg_py.svg_to_bytes(svg_string=svg, skip_system_fonts=True, font_files=_font_files()))
