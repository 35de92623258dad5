"""Which aliases are refused on their own, and what checking one loads."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import regex
from drboard_assembler.aliases import alias_problem


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
