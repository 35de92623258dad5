"""The terminal the CLI prints to: nothing the board stores reaches it as a control character.

A name, a title or a design string could hold ESC sequences (which clear a terminal or set its
title), C1 controls or bidirectional overrides (which reorder what a line shows). The consoles
the CLI prints with escape each of them as ``\\uXXXX`` in what they write, whatever renders it
(tables, lines, JSON), after rich has laid the text out and before its own styles are added.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import Any

from rich.console import Console
from rich.segment import Segment

#: C0 controls but newline and tab, DEL, C1 controls, and the bidirectional controls.
UNSAFE = re.compile("[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u2028\u2029\u202a-\u202e\u2066-\u2069]")


def printable(text: str) -> str:
    """The text with every control and bidirectional character written as ``\\uXXXX``."""
    return UNSAFE.sub(lambda found: f"\\u{ord(found.group()):04x}", text)


class SafeConsole(Console):
    """A rich console that escapes control characters in the text it writes (never in its own
    styles or cursor controls)."""

    def _render_buffer(self, buffer: Iterable[Segment]) -> str:
        return super()._render_buffer(
            segment if segment.control else Segment(printable(segment.text), segment.style)
            for segment in buffer)


def console(**options: Any) -> SafeConsole:
    return SafeConsole(highlight=False, **options)
