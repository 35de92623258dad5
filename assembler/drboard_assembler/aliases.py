"""Racer aliases: how two spellings are recognised as one racer, and which spellings are refused.

Two aliases are the same racer when they match after Unicode NFKC folding, case folding and
collapsing white space (``Ada``, ``ＡＤＡ`` and ``  ada `` are one racer). An alias that could pass
for another in print is refused outright: invisible and bidirectional control characters
(zero-width space, right-to-left override, ...), and letters of two scripts mixed in one alias
(a Cyrillic ``а`` among Latin letters).
"""

from __future__ import annotations

import unicodedata

#: Unicode categories that print as nothing, or reorder what follows.
_INVISIBLE = {"Cc", "Cf", "Co", "Cs", "Cn", "Zl", "Zp"}
#: Scripts whose letters are drawn alike: an alias mixing two of them is a lookalike.
_LOOKALIKE_SCRIPTS = ("LATIN", "CYRILLIC", "GREEK", "ARMENIAN", "CHEROKEE")


def alias_key(alias: str) -> str:
    """The key two spellings of one racer's alias share."""
    folded = unicodedata.normalize("NFKC", unicodedata.normalize("NFKC", alias).casefold())
    return " ".join(folded.split())


def alias_problem(alias: str) -> str | None:
    """Why an alias is refused, or None."""
    for char in alias:
        if unicodedata.category(char) in _INVISIBLE:
            return (f"contains the invisible or control character U+{ord(char):04X} "
                    f"({unicodedata.name(char, 'unnamed')})")
    scripts = sorted({script for char in unicodedata.normalize("NFKC", alias)
                      if (script := _script(char))})
    if len(scripts) > 1:
        return f"mixes {' and '.join(s.title() for s in scripts)} letters, which look alike"
    return None


def _script(char: str) -> str | None:
    if not char.isalpha():
        return None
    name = unicodedata.name(char, "")
    return next((script for script in _LOOKALIKE_SCRIPTS if name.startswith(script + " ")), None)
