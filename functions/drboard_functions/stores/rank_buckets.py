"""Counts of entries by score, laid out so that a rank reads three small counters, not the board.

A score key (see ``ranking.score_key``) is placed on a path of three (node, child) steps:

- qualified, ``0:<time ms>``: the root counts entries per second of time (``q027``), the
  second's node per 10 ms within it (``42``), the 10 ms node per millisecond (``7``);
- not qualified, ``1:<10000 - completion in basis points>``: the root counts per percent
  (``u093``), the percent's node per tenth (``4``), the tenth's node per basis point (``1``);
- qualified times of 1,000 s or more share one root child, ``q~``, with no nodes below it: the
  stores count inside it from the entries themselves (no realistic lap is that slow).

Children of one node compare as strings in the same order as the score keys they hold, so the
number of entries with a score key strictly lower than K is, at each step of K's path, the sum
of that node's counts for children lower than K's child. Every node is a bounded map (at most
1,102 children at the root, 100 below), so a rank costs the same on a board of 1,000 racers as
on one of 100,000, and an entry that changes moves at most five counters.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable, Mapping

ROOT = ""
OVERFLOW = "q~"
OVERFLOW_START = "0:000001000000"  # the lowest score key counted under OVERFLOW
_QUALIFIED, _UNQUALIFIED = "0:", "1:"
_OVERFLOW_MS = 1_000_000

Step = tuple[str, str]  # (node, child)


def path(score_key: str) -> list[Step]:
    """The (node, child) steps that hold ``score_key``'s count, root first."""
    kind, digits = score_key[:2], score_key[2:]
    if kind not in (_QUALIFIED, _UNQUALIFIED) or not digits.isdigit():
        raise ValueError(f"not a score key: {score_key!r}")
    value = int(digits)
    if kind == _QUALIFIED:
        if value >= _OVERFLOW_MS:
            return [(ROOT, OVERFLOW)]
        top, middle, leaf = f"q{value // 1000:03d}", f"{value // 10 % 100:02d}", str(value % 10)
    else:
        top, middle, leaf = f"u{value // 100:03d}", str(value // 10 % 10), str(value % 10)
    return [(ROOT, top), (top, middle), (f"{top}/{middle}", leaf)]


def changes(added: str | None, removed: str | None) -> dict[str, dict[str, int]]:
    """Per node, how each child's count moves when the entry with score key ``removed`` (or
    none) is replaced by one with ``added`` (or none). Moves that cancel out are left out."""
    moves: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))
    for score_key, step in ((added, +1), (removed, -1)):
        if score_key is not None:
            for node, child in path(score_key):
                moves[node][child] += step
    return {node: kept for node, children in moves.items()
            if (kept := {child: n for child, n in children.items() if n})}


def tally(score_keys: list[str]) -> dict[str, dict[str, int]]:
    """Per node, the counts of a board holding entries with these score keys."""
    counts: dict[str, dict[str, int]] = defaultdict(lambda: defaultdict(int))
    for score_key in score_keys:
        for node, child in path(score_key):
            counts[node][child] += 1
    return {node: dict(children) for node, children in counts.items()}


def count_lower(score_key: str, counts_of: Callable[[str], Mapping[str, int]]) -> int:
    """How many counted entries have a score key strictly lower than ``score_key``, reading each
    node of its path through ``counts_of``. For a key under OVERFLOW this leaves out the entries
    under OVERFLOW itself: the caller counts those between OVERFLOW_START and the key."""
    return sum(count for node, child in path(score_key)
               for below, count in counts_of(node).items() if below < child)


def in_overflow(score_key: str) -> bool:
    return path(score_key)[0][1] == OVERFLOW
