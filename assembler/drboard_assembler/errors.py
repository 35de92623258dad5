"""The one error the assembler raises: it names the file and the field at fault."""

from __future__ import annotations

import re
from collections.abc import Sequence

_CONTROL = re.compile(r"[\x00-\x1f\x7f]")


class AssemblyError(Exception):
    """Bad input: a file is missing, malformed, oversized or inconsistent.

    ``flag`` names the command-line flag that supplies the value, when one does. ``given`` is the
    path the racer gave (a folder or an archive), which ``file`` is inside.
    """

    def __init__(self, file: str, field: str, problem: str, *, flag: str | None = None) -> None:
        self.file = file
        self.field = field
        self.problem = problem
        self.flag = flag
        self.given: str | None = None
        super().__init__(problem)

    def __str__(self) -> str:
        # dict.fromkeys drops the file when it is the given path itself
        where = ": ".join(dict.fromkeys(printable(part) for part in (self.given, self.file, self.field)
                                        if part))
        hint = f" (use {self.flag})" if self.flag else ""
        return f"{where}: {printable(self.problem)}{hint}"


def printable(text: str) -> str:
    """The text on one line and encodable: bytes of a file name that are not UTF-8 (which Python
    keeps as lone surrogates) and control characters are shown escaped (``\\xff``, ``\\n``)."""
    try:
        text = text.encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a surrogate no file name holds (from a JSON "\ud800")
        text = text.encode("utf-8", "backslashreplace").decode("utf-8")
    return _CONTROL.sub(lambda match: repr(match[0])[1:-1], text)


def field_path(loc: Sequence[int | str]) -> str:
    """A pydantic error location as the record reads: ``evaluations[0].laps[2].time_ms``."""
    path = ""
    for part in loc:
        if isinstance(part, int):
            path += f"[{part}]"
        else:
            path += f".{part}" if path else str(part)
    return path
