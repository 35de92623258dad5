"""Names: how two spellings of an alias are recognised as one racer, which spellings are refused,
and which text a record may hold at all.

Two aliases are the same racer when they match after Unicode NFKC folding, case folding and
collapsing white space (``Ada``, ``ＡＤＡ`` and ``  ada `` are one racer). An alias that could pass
for another in print is refused outright:

- any invisible, default-ignorable or control character (zero-width space, right-to-left
  override, combining grapheme joiner, variation selectors, Hangul fillers, the Braille blank,
  a space other than the plain one, ...);
- letters of scripts that are not written together (UTS #39's "highly restrictive" level: one
  script, or Latin with the Chinese, Japanese or Korean scripts), so a Cyrillic ``а`` among
  Latin letters or Lisu letters beside Latin ones are refused;
- and, where the board knows its racers, an alias whose confusable skeleton (UTS #39) is
  another racer's: ``АСЕ`` in Cyrillic beside a Latin ``ACE`` (see :func:`confusable_skeleton`).

The Unicode properties (default-ignorable code points) come from ``regex`` and the scripts and
confusable skeletons from ``disarm``; both are imported when a name that needs them is first
checked (an alias in ASCII needs neither, to be checked or for its skeleton), so that reading
stored records (which are never checked again) does not load them.

Every other name and text a record holds is bounded to printable text by :func:`text_problem`:
no control, format (bidirectional controls included), surrogate, private-use or separator
character.
"""

from __future__ import annotations

import unicodedata
from collections.abc import Iterator
from functools import cache
from typing import Any

#: Unicode categories that print as nothing, reorder what follows, or are not characters.
_INVISIBLE = {"Cc", "Cf", "Co", "Cs", "Cn", "Zl", "Zp"}
#: Categories no printable text holds: controls (C0, DEL, C1), format characters (bidirectional
#: controls, zero-width characters), surrogates, private use, line and paragraph separators.
_NOT_TEXT = {"Cc", "Cf", "Co", "Cs", "Zl", "Zp"}
#: Characters that are drawn as blank space without being white space or default-ignorable.
_BLANK = {"\u2800"}  # BRAILLE PATTERN BLANK
#: The script sets UTS #39 allows in one identifier at its "highly restrictive" level.
_WRITTEN_TOGETHER = (
    frozenset({"LATIN", "HAN", "HIRAGANA", "KATAKANA"}),
    frozenset({"LATIN", "HAN", "BOPOMOFO"}),
    frozenset({"LATIN", "HAN", "HANGUL"}),
)


def alias_key(alias: str) -> str:
    """The key two spellings of one racer's alias share."""
    folded = unicodedata.normalize("NFKC", unicodedata.normalize("NFKC", alias).casefold())
    return " ".join(folded.split())


def alias_problem(alias: str) -> str | None:
    """Why an alias is refused on its own (whoever else is on the board), or None."""
    for char in alias:
        if _invisible(char):
            return (f"contains the invisible or control character U+{ord(char):04X} "
                    f"({unicodedata.name(char, 'unnamed')})")
    if alias.isascii():  # Latin letters, and digits and signs common to every script
        return None
    scripts = _scripts(unicodedata.normalize("NFKC", alias))
    if len(scripts) > 1 and not any(scripts <= allowed for allowed in _WRITTEN_TOGETHER):
        named = " and ".join(sorted(script.title() for script in scripts))
        return f"mixes {named} letters, which are not written together (a lookalike)"
    return None


def confusable_skeleton(alias: str) -> str:
    """The alias's confusable skeleton (UTS #39, with ``1``/``l``/``I`` and ``0``/``O`` as one):
    two aliases with one skeleton could pass for each other in print."""
    # Before any case folding: ``I`` passes for ``l`` only while it is a capital.
    spelled = " ".join(unicodedata.normalize("NFKC", alias).split())
    if spelled.isascii():  # each character's skeleton on its own: disarm's tables stay unloaded
        skeleton = " ".join(spelled.translate(_ASCII_SKELETON).split())
    else:
        from disarm import skeleton_key

        skeleton = skeleton_key(spelled, digit_policy="tr39")
    return skeleton or alias_key(alias)


#: The skeleton of each printable ASCII character, as disarm's ``skeleton_key`` gives it (its
#: case folded, ``0``/``O``, ``1``/``l``/``I``/``|`` as one, quotes as apostrophes). An ASCII
#: text's skeleton is its characters' skeletons side by side, white space collapsed; a test
#: checks both against disarm.
_ASCII_SKELETON = str.maketrans(
    {chr(code): chr(code).lower() for code in range(32, 127)}
    | {"0": "o", "1": "l", "I": "l", "|": "l", '"': "''", "`": "'"})


def text_problem(text: str) -> str | None:
    """Why a text (a model name, a track's name, a design string) is not printable, or None."""
    if text.isprintable():  # holds none of _NOT_TEXT's categories: no need to look closer
        return None
    for char in text:
        if unicodedata.category(char) in _NOT_TEXT:
            return (f"holds the control or invisible character U+{ord(char):04X} "
                    f"({unicodedata.name(char, 'unnamed')}): only printable text is kept")
    return None


def texts(value: Any, path: tuple[str | int, ...] = ()) -> Iterator[tuple[tuple[str | int, ...], str]]:
    """Every string in a JSON-like value (dictionary keys included), with where it is."""
    if isinstance(value, str):
        yield path, value
    elif isinstance(value, dict):
        for key, item in value.items():
            name = str(key)
            yield (*path, name), name
            yield from texts(item, (*path, name))
    elif isinstance(value, list | tuple):
        for index, item in enumerate(value):
            yield from texts(item, (*path, index))


def _invisible(char: str) -> bool:
    category = unicodedata.category(char)
    if category in _INVISIBLE or (category == "Zs" and char != " ") or char in _BLANK:
        return True
    # No ASCII character is default-ignorable: regex's tables are loaded for the others only.
    return not char.isascii() and _default_ignorable().match(char) is not None


@cache
def _default_ignorable() -> Any:
    import regex

    return regex.compile(r"\p{Default_Ignorable_Code_Point}")


def _scripts(text: str) -> frozenset[str]:
    """The scripts of the text's letters (common and inherited characters belong to all)."""
    from disarm import detect_scripts

    return frozenset(script.name for script in detect_scripts(text))
