"""The one error the assembler raises: it names the file and the field at fault."""

from __future__ import annotations

from collections.abc import Sequence


class AssemblyError(Exception):
    """Bad input: a file is missing, malformed, oversized or inconsistent.

    ``flag`` names the command-line flag that supplies the value, when one does.
    """

    def __init__(self, file: str, field: str, problem: str, *, flag: str | None = None) -> None:
        self.file = file
        self.field = field
        self.problem = problem
        self.flag = flag
        super().__init__(str(self))

    def __str__(self) -> str:
        where = f"{self.file}: {self.field}" if self.field else self.file
        hint = f" (use {self.flag})" if self.flag else ""
        return f"{where}: {self.problem}{hint}"


def field_path(loc: Sequence[int | str]) -> str:
    """A pydantic error location as the record reads: ``evaluations[0].laps[2].time_ms``."""
    path = ""
    for part in loc:
        if isinstance(part, int):
            path += f"[{part}]"
        else:
            path += f".{part}" if path else str(part)
    return path
