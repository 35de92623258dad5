"""The score-bucket layout: counting along a key's path gives the entries strictly below it."""

from __future__ import annotations

import random

import pytest
from drboard_functions.stores import rank_buckets


def qualified(ms: int) -> str:
    return f"0:{ms:012d}"


def unqualified(basis_points: int) -> str:
    return f"1:{10_000 - basis_points:05d}"


EDGES = [qualified(ms) for ms in (0, 1, 9, 10, 999, 1_000, 12_345, 999_999, 1_000_000, 86_400_000)]
EDGES += [unqualified(bp) for bp in (10_000, 9_999, 5_000, 100, 1, 0)]


def lower_by_counters(keys: list[str], probe: str) -> int:
    counts = rank_buckets.tally(keys)
    below = rank_buckets.count_lower(probe, lambda node: counts.get(node, {}))
    if rank_buckets.in_overflow(probe):  # what the stores count from the entries themselves
        below += sum(rank_buckets.OVERFLOW_START <= key < probe for key in keys)
    return below


def test_counts_along_the_path_are_the_keys_strictly_below() -> None:
    rng = random.Random(7)
    keys = EDGES + [qualified(rng.choice([rng.randrange(8_000, 30_000), rng.randrange(2_000_000)]))
                    for _ in range(400)]
    keys += [unqualified(rng.randrange(10_001)) for _ in range(100)]
    for probe in [*sorted(set(keys)), qualified(12_344), qualified(1_500_000), unqualified(1_234)]:
        assert lower_by_counters(keys, probe) == sum(key < probe for key in keys), probe


def test_a_replaced_entry_moves_only_the_counts_that_differ() -> None:
    assert rank_buckets.changes(qualified(12_345), qualified(12_345)) == {}
    moved = rank_buckets.changes(qualified(12_345), qualified(12_349))
    assert moved == {"q012/34": {"5": 1, "9": -1}}
    across = rank_buckets.changes(qualified(9_000), unqualified(5_000))
    assert across[rank_buckets.ROOT] == {"q009": 1, "u050": -1}
    assert sum(len(children) for children in across.values()) == 6


@pytest.mark.parametrize("key", ["", "0:", "2:000000012345", "0:12a45", "1:-0001"])
def test_a_key_that_is_not_a_score_key_is_refused(key: str) -> None:
    with pytest.raises(ValueError, match="not a score key"):
        rank_buckets.path(key)
