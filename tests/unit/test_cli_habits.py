"""CLI habits a racer notices: a batch push that says what it does and does it, a saved racer
that stays saved, and tables that keep their words whole at 80 columns."""

from __future__ import annotations

import re
from pathlib import Path

from click.testing import CliRunner
from drboard_cli import config
from drboard_cli.main import cli

EXAMPLES = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())
COUNTER_CLOCKWISE = [p for p in EXAMPLES if not p.name.endswith("-cw")]
CLOCKWISE = [p for p in EXAMPLES if p.name.endswith("-cw")]


def run(*args: str | Path, columns: int = 80) -> tuple[int, str, str]:
    result = CliRunner(env={"COLUMNS": str(columns)}).invoke(cli, [str(a) for a in args],
                                                             catch_exceptions=False)
    return result.exit_code, result.stdout, result.stderr


def create_final(*options: str) -> None:
    code, _, err = run("board", "create", "club-final", "--title", "Club final", "--track",
                       "reInvent2019", *options)
    assert code == 0, err


def test_a_batch_with_a_run_that_does_not_belong_pushes_none_and_names_it() -> None:
    create_final()
    code, _, err = run("push", *COUNTER_CLOCKWISE[:3], *CLOCKWISE, "--board", "club-final")
    assert code == 2
    assert str(CLOCKWISE[0]) in err and "nothing was pushed" in err
    assert run("pull", "--board", "club-final", "--format", "json")[1].count('"racer"') == 0


def test_a_batch_against_a_cooldown_is_refused_up_front() -> None:
    create_final("--cooldown", "30m")
    code, _, err = run("push", COUNTER_CLOCKWISE[0], COUNTER_CLOCKWISE[0], "--board", "club-final")
    assert code == 1 and "one at a time" in err and "nothing was pushed" in err


def test_a_batch_says_what_it_will_do_and_sums_up() -> None:
    create_final()
    code, out, err = run("push", *COUNTER_CLOCKWISE, "--board", "club-final")
    assert code == 0, err
    assert f"Pushing {len(COUNTER_CLOCKWISE)} runs to club-final" in err
    assert f"Pushed all {len(COUNTER_CLOCKWISE)} runs." in err
    assert out.count("rank ") == len(COUNTER_CLOCKWISE)


def test_a_racer_saved_by_configure_stays_saved_after_a_push() -> None:
    assert run("configure", "--racer", "Ada")[0] == 0
    assert run("push", COUNTER_CLOCKWISE[0])[0] == 0
    assert config.load_settings()["racer"] == "Ada"
    assert config.default_racer() == "Ada"


def test_tables_at_80_columns_keep_their_words_whole() -> None:
    create_final("--cooldown", "30m")
    run("board", "update", "club-final", "--title", "Club final night two")
    run("push", *COUNTER_CLOCKWISE)
    run("push", COUNTER_CLOCKWISE[0], "--board", "club-final")
    racer = run("pull", "--track", "reInvent2019", "--format", "json")[1]
    name = re.search(r'"racer": "([^"]+)"', racer)[1]  # type: ignore[index]
    words = {"reInvent2019_track", "club-final", "Submitted", "laps to qualify"}
    for args in (("boards",), ("status", "--racer", name), ("history", "--racer", name),
                 ("audit", "club-final"), ("pull", "--track", "reInvent2019")):
        code, out, err = run(*args)
        assert code == 0, err
        assert max(len(line) for line in out.splitlines()) <= 80, args
        flat = " ".join(re.sub(r"[│┃]", " ", out).split())
        for word in words:
            cut = [word[:n] for n in range(3, len(word)) if f"{word[:n]} " in flat
                   and word not in flat and word[n:] in flat]
            assert not cut, (args, word, cut)
    audit = run("audit", "club-final")[1]
    assert "organiser (this" in audit and "title → Club final" in audit
    assert '{"title"' not in audit
