"""Which aliases are refused on their own, and what checking one loads."""

from __future__ import annotations

import itertools
import json
import random
import subprocess
import sys

import pytest
import regex
from disarm import skeleton_key
from drboard_assembler.aliases import alias_key, alias_problem, confusable_skeleton


def test_no_ascii_character_is_default_ignorable() -> None:
    """What lets an ASCII alias be checked without regex's Unicode tables."""
    ignorable = regex.compile(r"\p{Default_Ignorable_Code_Point}")
    assert [hex(code) for code in range(128) if ignorable.match(chr(code))] == []


@pytest.mark.parametrize(("alias", "problem"), [
    ("Ada\u200bLovelace", "U+200B"),  # zero-width space
    ("Ada\u00adLovelace", "U+00AD"),  # soft hyphen: default-ignorable, not a control
    ("Ada\x07", "U+0007"),  # an ASCII control
    ("Ada\tLovelace", "U+0009"),
    ("\u0410da", "mixes Cyrillic and Latin"),
])
def test_invisible_characters_and_mixed_scripts_are_refused(alias: str, problem: str) -> None:
    found = alias_problem(alias)
    assert found is not None and problem in found


@pytest.mark.parametrize("alias", ["Ada", "Ada Lovelace", "ada_2019-v7", "R2-D2 (club)", "李小龙", "Ada 李"])
def test_printable_aliases_of_one_script_pass(alias: str) -> None:
    assert alias_problem(alias) is None


def test_an_ascii_alias_is_checked_without_loading_the_unicode_tables() -> None:
    """A racer's `drboard push` checks the alias: in ASCII, regex and disarm stay unloaded."""
    probe = ("import json, sys; from drboard_assembler.aliases import alias_problem; "
             "print(json.dumps([alias_problem('Ada Lovelace-2'), "
             "sorted(m for m in ('regex', 'disarm') if m in sys.modules)]))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == [None, []]


PRINTABLE_ASCII = [chr(code) for code in range(32, 127)]


def _disarms(alias: str) -> str:
    return skeleton_key(" ".join(alias.split()), digit_policy="tr39")


def test_an_ascii_alias_has_the_skeleton_disarm_gives_it() -> None:
    """An ASCII alias's skeleton is worked out without disarm: the same as disarm's for every
    pair of printable characters and for random aliases, so lookalikes are caught alike."""
    pairs = ["".join(pair) for pair in itertools.product(PRINTABLE_ASCII, repeat=2)]
    rng = random.Random(39)
    aliases = ["".join(rng.choice(PRINTABLE_ASCII) for _ in range(rng.randint(1, 30)))
               for _ in range(5000)]
    for alias in [*pairs, *aliases, "paypaI", "0llie", "O1lie", "Ada  Lovelace", '"Ada"']:
        assert confusable_skeleton(alias) == (_disarms(alias) or alias_key(alias)), alias


@pytest.mark.parametrize(("one", "other"), [("0llie", "Ollie"), ("paypaI", "paypal"), ("ADA", "ada"),
                                            ("Ada Lovelace", "Ada  Lovelace")])
def test_ascii_lookalikes_share_a_skeleton(one: str, other: str) -> None:
    assert confusable_skeleton(one) == confusable_skeleton(other)


def test_a_non_ascii_alias_still_takes_disarms_skeleton() -> None:
    assert confusable_skeleton("\u0410\u0421\u0415") == confusable_skeleton("ACE")  # Cyrillic АСЕ


def test_an_ascii_alias_s_skeleton_loads_no_unicode_table() -> None:
    probe = ("import json, sys; from drboard_assembler.aliases import confusable_skeleton; "
             "print(json.dumps([confusable_skeleton('0llie-2'), "
             "sorted(m for m in ('regex', 'disarm') if m in sys.modules)]))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True, check=True)
    assert json.loads(done.stdout) == ["ollie-2", []]
