"""The drboard command as a racer uses it, on the embedded board in a temporary user folder."""

from __future__ import annotations

import csv
import io
import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner
from drboard_assembler import Record
from drboard_cli.main import cli
from drboard_functions import display

EXAMPLES = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())
COUNTER_CLOCKWISE = [p for p in EXAMPLES if not p.name.endswith("-cw")]


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def run(runner: CliRunner, *args: str | Path) -> tuple[int, str, str]:
    result = runner.invoke(cli, [str(a) for a in args], catch_exceptions=False)
    return result.exit_code, result.stdout, result.stderr


def push_examples(runner: CliRunner) -> None:
    code, _, err = run(runner, "push", *EXAMPLES)
    assert code == 0, err


def test_push_then_pull_shows_the_standings_fastest_first(runner: CliRunner) -> None:
    push_examples(runner)
    code, out, _ = run(runner, "pull", "--track", "reInvent2019", "--format", "json")
    assert code == 0
    page = json.loads(out)
    assert page["board"]["board_id"] == "reInvent2019_track"
    assert page["board"]["participants"] == len(COUNTER_CLOCKWISE)
    entries = page["entries"]
    qualified = [e["time_ms"] for e in entries if e["qualified"]]
    assert qualified == sorted(qualified)
    assert entries[0]["rank"] == 1 and entries[0]["gap_ms"] == 0
    assert [e["rank"] for e in entries] == sorted(e["rank"] for e in entries)
    assert not entries[-1]["qualified"], "a model that never finishes still gets a place, last"


def test_pull_table_shows_readable_times_gaps_and_designs(runner: CliRunner) -> None:
    push_examples(runner)
    code, out, _ = run(runner, "pull", "--track", "Smile Speedway")
    assert code == 0
    assert "Smile Speedway" in out
    assert "leader" in out
    assert " s" in out and "+" in out
    assert "PPO" in out and "SAC" in out


def test_pull_csv_and_markdown(runner: CliRunner, tmp_path: Path) -> None:
    push_examples(runner)
    target = tmp_path / "board.csv"
    code, _, _ = run(runner, "pull", "--board", "reInvent2019_track", "--format", "csv",
                     "-o", target)
    assert code == 0
    rows = list(csv.DictReader(io.StringIO(target.read_text())))
    assert len(rows) == len(COUNTER_CLOCKWISE)
    assert rows[0]["rank"] == "1" and rows[0]["gap_s"] == "0.000"
    code, out, _ = run(runner, "pull", "--track", "reInvent2019", "--format", "markdown", "--top", "2")
    assert code == 0
    assert out.count("\n| ") == 3  # header and two entries


@pytest.mark.parametrize("form", ["table", "markdown"])
def test_the_standings_count_one_racer_as_one_racer(runner: CliRunner, form: str) -> None:
    code, _, err = run(runner, "push", EXAMPLES[0])
    assert code == 0, err
    _, out, _ = run(runner, "pull", "--track", "reInvent2019", "--format", form)
    assert "1 racer ·" in out and "1 racers" not in out
    push_examples(runner)
    _, out, _ = run(runner, "pull", "--track", "reInvent2019", "--format", form)
    assert f"{len(COUNTER_CLOCKWISE)} racers ·" in out


def test_top_limits_the_entries(runner: CliRunner) -> None:
    push_examples(runner)
    _, out, _ = run(runner, "pull", "--track", "reInvent2019", "--top", "3", "--format", "json")
    assert [e["rank"] for e in json.loads(out)["entries"]] == [1, 2, 3]


def test_clockwise_runs_rank_on_their_own_board(runner: CliRunner) -> None:
    push_examples(runner)
    code, out, _ = run(runner, "boards", "--format", "json")
    assert code == 0
    boards = {b["board_id"]: b for b in json.loads(out)}
    assert "reInvent2019_track" in boards
    if len(EXAMPLES) > len(COUNTER_CLOCKWISE):
        assert boards["reInvent2019_track_cw"]["direction"] == "cw"


def test_a_push_names_the_board_it_went_to(runner: CliRunner, tmp_path: Path) -> None:
    """A racer who has not joined an event (or mistyped the join) sees that the push stayed on
    this computer, and what to type to race at the event."""
    code, out, err = run(runner, "--db", tmp_path / "mine.db", "push", EXAMPLES[0])
    assert code == 0 and "rank 1 of 1" in out
    assert f"Pushed to the board on this computer ({tmp_path / 'mine.db'})." in err
    assert "`drboard join`" in err


def test_pushing_the_same_run_twice_changes_nothing(runner: CliRunner) -> None:
    run(runner, "push", EXAMPLES[0])
    code, out, _ = run(runner, "push", EXAMPLES[0])
    assert code == 0
    assert "already on the board" in out
    _, out, _ = run(runner, "history", "--format", "json")
    assert len(json.loads(out)) == 1


def test_history_defaults_to_the_racer_who_pushed(runner: CliRunner) -> None:
    run(runner, "push", EXAMPLES[0])
    code, out, _ = run(runner, "history")
    assert code == 0
    assert "★" in out


def test_history_without_any_racer_says_which_flag_to_use(runner: CliRunner) -> None:
    code, _, err = run(runner, "history")
    assert code == 2
    assert "--racer" in err


def test_show_tells_how_the_model_was_built(runner: CliRunner) -> None:
    push_examples(runner)
    _, out, _ = run(runner, "pull", "--track", "reInvent2019", "--format", "json")
    leader = json.loads(out)["entries"][0]["racer"]
    code, out, _ = run(runner, "show", leader.upper(), "--track", "reInvent2019")
    assert code == 0
    assert "Hyperparameters" in out and "Action space" in out and "Evaluation laps" in out
    code, out, _ = run(runner, "show", leader, "--track", "reInvent2019", "--format", "json")
    view = json.loads(out)
    assert view["entry"]["rank"] == 1
    assert view["record"]["design"]["hyperparameters"]


def test_show_says_how_long_the_model_trained_as_the_web_page_does(
        runner: CliRunner, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "200")  # the training row on one line
    push_examples(runner)
    records = [Record.model_validate_json(run(runner, "assemble", e)[1]) for e in COUNTER_CLOCKWISE]
    record = next(r for r in records if r.training and r.training.training_time_s >= 60)
    assert record.training is not None
    code, out, err = run(runner, "show", record.racer, "--track", record.track)
    assert code == 0, err
    assert f"{display.duration(int(record.training.training_time_s))}, best reward" in out


def test_show_unknown_racer_fails(runner: CliRunner) -> None:
    push_examples(runner)
    code, _, err = run(runner, "show", "Nobody", "--track", "reInvent2019")
    assert code == 1
    assert "Nobody" in err


def test_dry_run_sends_nothing(runner: CliRunner) -> None:
    code, out, _ = run(runner, "push", "--dry-run", *EXAMPLES)
    assert code == 0
    assert "dry run" in out
    _, out, _ = run(runner, "boards", "--format", "json")
    assert json.loads(out) == []


def test_one_bad_folder_means_nothing_is_pushed(runner: CliRunner, tmp_path: Path) -> None:
    bad = tmp_path / "bad-run"
    shutil.copytree(EXAMPLES[0], bad)
    (metadata,) = bad.rglob("model_metadata.json")
    metadata.write_text('{"action_space": [')
    code, out, err = run(runner, "push", EXAMPLES[1], bad)
    assert code == 2
    assert "model_metadata.json" in err
    assert "Traceback" not in out + err
    _, out, _ = run(runner, "boards", "--format", "json")
    assert json.loads(out) == []


def test_unknown_track_lists_the_closest_matches(runner: CliRunner) -> None:
    code, _, err = run(runner, "pull", "--track", "reInvnt2019")
    assert code == 2
    assert "reInvent2019_track" in err


def test_a_board_nobody_pushed_to_is_a_failure_not_a_crash(runner: CliRunner) -> None:
    code, _, err = run(runner, "pull", "--track", "Oval_track")
    assert code == 1
    assert "Oval_track" in err


def test_flags_override_the_files(runner: CliRunner) -> None:
    code, out, _ = run(runner, "push", EXAMPLES[0], "--racer", "Guest", "--model", "borrowed")
    assert code == 0
    assert "Guest" in out and "borrowed" in out


def test_assemble_saves_a_valid_record(runner: CliRunner, tmp_path: Path) -> None:
    target = tmp_path / "record.json"
    code, _, _ = run(runner, "assemble", EXAMPLES[0], "-o", target)
    assert code == 0
    record = Record.model_validate_json(target.read_text())
    assert record.track == "reInvent2019_track"


def test_db_option_and_environment_choose_the_board_file(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    chosen = tmp_path / "event" / "board.db"
    code, _, _ = run(runner, "--db", chosen, "push", EXAMPLES[0])
    assert code == 0 and chosen.exists()
    monkeypatch.setenv("DRBOARD_DB", str(chosen))
    _, out, _ = run(runner, "boards", "--format", "json")
    assert len(json.loads(out)) == 1


def test_default_board_lives_in_the_user_data_folder(runner: CliRunner, user_dirs: Path) -> None:
    run(runner, "push", EXAMPLES[0])
    assert list(user_dirs.rglob("board.db"))
