"""Writes ``fonts/widths.json``: the advance width of every character the card fonts have, read
from the fonts themselves with fontTools, so that measuring a name needs no font library at run
time (fontTools is a test dependency: ``tests/unit/test_cards.py`` checks the committed table
against the fonts).

Run ``python -m drboard_functions.cards.widths > functions/drboard_functions/cards/fonts/widths.json``
after changing a font.
"""

from __future__ import annotations

import json
from importlib.resources import files
from typing import Any

from .metrics import FACES


def widths_table() -> dict[str, Any]:
    """Each face's advance widths (font units) in runs of consecutive code points, and the
    width of its missing-glyph box (what a character the font lacks is drawn as)."""
    from fontTools.ttLib import TTFont

    fonts = files("drboard_functions.cards") / "fonts"
    faces: dict[str, Any] = {}
    units_per_em = 0
    version = ""
    for face, filename in FACES.items():
        with (fonts / filename).open("rb") as stream:
            font = TTFont(stream)
        units_per_em = font["head"].unitsPerEm
        version = f"{font['name'].getDebugName(1)} {font['name'].getDebugName(5)}"
        metrics = font["hmtx"].metrics
        advances = {code: metrics[glyph][0] for code, glyph in font.getBestCmap().items()}
        runs: list[list[Any]] = []
        for code in sorted(advances):
            if runs and runs[-1][0] + len(runs[-1][1]) == code:
                runs[-1][1].append(advances[code])
            else:
                runs.append([code, [advances[code]]])
        faces[face] = {"file": filename, "missing": metrics[".notdef"][0], "runs": runs}
    return {"font": version, "units_per_em": units_per_em, "faces": faces}


def main() -> None:
    print(json.dumps(widths_table(), separators=(",", ":")))


if __name__ == "__main__":
    main()
