"""`drboard push --watch`: each evaluation of a training folder pushed once, as it finishes.

The watcher runs against the embedded board with a fake clock shared by the watcher (its sleeps
advance it) and the board (its cooldowns and windows read it), so nothing here really waits.
"""

from __future__ import annotations

import io
import json
import os
import shutil
import time
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from drboard_assembler import Overrides, Record, assemble
from drboard_cli.main import cli
from drboard_cli.watch import MAX_RETRY_S, PushedEvaluations, Watcher, WatchSummary
from drboard_functions import errors as domain
from drboard_functions.models.requests import BoardSpec
from drboard_functions.models.views import PushReceipt
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore
from rich.console import Console

EXAMPLES = Path(__file__).parents[2] / "examples"
SETTLE_S = 60.0
HOUR_S = 3600.0


class FakeTime:
    def __init__(self) -> None:
        self.start = self.now = float(int(time.time()))
        self.sleeps: list[float] = []

    def time(self) -> float:
        return self.now

    def utc(self) -> datetime:
        return datetime.fromtimestamp(self.now, UTC)

    def sleep(self, seconds: float) -> None:
        self.sleeps.append(seconds)
        self.now += seconds


class CountingBoard:
    """The board, counting what reaches it."""

    def __init__(self, board: LeaderboardService) -> None:
        self.board = board
        self.pushed: list[str] = []

    def push(self, record: Record, board_id: str | None) -> PushReceipt:
        self.pushed.append(record.submission_id)
        return self.board.push(record, board_id)


class Scene:
    """A training folder, the embedded board and a watcher on them."""

    def __init__(self, tmp_path: Path, example: str) -> None:
        self.clock = FakeTime()
        self.folder = tmp_path / example
        shutil.copytree(EXAMPLES / example, self.folder)
        for name in self.evaluations():
            self.age(name, HOUR_S)
        self.service = LeaderboardService(SqliteStore(tmp_path / "b.db"), clock=self.clock.utc)
        self.board = CountingBoard(self.service)
        self.output = io.StringIO()

    def evaluations(self) -> list[Path]:
        return sorted((p for p in (self.folder / "metrics").rglob("*.json") if "valuation" in p.name),
                      key=lambda p: p.as_posix())

    def watcher(self, board: Any = None, *, board_id: str | None = None,
                only_new: bool = False, memory: PushedEvaluations | None = None) -> Watcher:
        console = Console(file=self.output, width=300, highlight=False, color_system=None)
        return Watcher(self.folder, board or self.board, Overrides(), board_id, console=console,
                       only_new=only_new, settle_s=SETTLE_S, sleep=self.clock.sleep,
                       clock=self.clock.time, memory=memory)

    def write(self, name: str, content: bytes | str) -> None:
        """Write a file now, as the training does."""
        path = self.folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(content.encode() if isinstance(content, str) else content)
        self.age(name, 0)

    def age(self, name: str | Path, seconds: float) -> None:
        mtime = self.clock.now - seconds
        os.utime(self.folder / name, (mtime, mtime))

    def history(self, racer: str) -> list[str]:
        return [item.submission_id for item in self.service.history(racer, None)]

    def printed(self) -> str:
        return self.output.getvalue()


NAMED = "evaluation-20240315101544.json"  # comet's evaluation that its parameters name
NEW = "metrics/evaluation/evaluation-20240316090000.json"


def evaluation_file(laps: int | None = None) -> str:
    """Comet's other evaluation (three complete laps), or its first laps, as DeepRacer writes
    the file again after each lap."""
    source = EXAMPLES / "comet-sac-drfc/metrics/evaluation/evaluation-20240315093012.json"
    content = json.loads(source.read_text())
    content["metrics"] = content["metrics"][:laps]
    return json.dumps(content)


def announce(scene: Scene, name: str) -> None:
    """DeepRacer-for-Cloud writes an evaluation's parameters, naming its metrics file, first."""
    params = (scene.folder / "evaluation_params.yaml").read_text()
    scene.write("evaluation_params.yaml", params.replace(NAMED, Path(name).name))


@pytest.fixture
def drifter(tmp_path: Path) -> Scene:
    return Scene(tmp_path, "drifter-ppo-drfc")  # three evaluations, one named by its params


@pytest.fixture
def comet(tmp_path: Path) -> Scene:
    scene = Scene(tmp_path, "comet-sac-drfc")
    for path in scene.evaluations():
        if path.name != NAMED:
            path.unlink()
    return scene


# ---- what gets pushed ------------------------------------------------------------------------


def test_evaluations_already_in_the_folder_are_each_pushed_once(drifter: Scene) -> None:
    watcher = drifter.watcher()
    watcher.poll()
    watcher.poll()

    history = drifter.history("Drifter")
    assert len(history) == 3, "one submission per evaluation metrics file"
    assert sorted(drifter.board.pushed) == sorted(history)
    for path in drifter.evaluations():
        assert drifter.printed().count(path.name) == 1
    assert watcher.summary.pushed == 3


def test_each_submission_holds_its_own_evaluation(drifter: Scene) -> None:
    drifter.watcher().poll()
    best_laps = sorted(item.best_lap_ms for item in drifter.service.history("Drifter", None))
    assert best_laps == [9968, 10390, 10712]


def test_only_new_leaves_out_what_was_there_and_pushes_what_comes(comet: Scene) -> None:
    watcher = comet.watcher(only_new=True)
    watcher.poll()
    assert comet.history("Comet") == []

    announce(comet, NEW)
    comet.write(NEW, evaluation_file())
    watcher.poll()
    assert len(comet.history("Comet")) == 1
    assert NEW in comet.printed()


def test_a_new_evaluation_is_pushed_on_the_next_poll(comet: Scene) -> None:
    watcher = comet.watcher()
    watcher.poll()
    assert len(comet.history("Comet")) == 1

    comet.clock.sleep(10)
    announce(comet, NEW)
    comet.write(NEW, evaluation_file())
    watcher.poll()
    assert len(comet.history("Comet")) == 2
    assert f"{NEW}: Comet" in comet.printed()


def test_an_evaluation_is_pushed_only_once_all_its_laps_are_in(comet: Scene) -> None:
    watcher = comet.watcher()
    watcher.poll()
    announce(comet, NEW)  # NUMBER_OF_TRIALS: 3
    for laps in (1, 2):
        comet.write(NEW, evaluation_file(laps))
        watcher.poll()
        comet.clock.sleep(20)
        assert len(comet.history("Comet")) == 1, f"pushed with {laps} of 3 laps"

    comet.write(NEW, evaluation_file(3))
    watcher.poll()
    newest = comet.service.history("Comet", None)[-1]
    assert newest.laps_completed == 3


def test_a_half_written_file_is_not_pushed_until_complete(comet: Scene) -> None:
    watcher = comet.watcher()
    watcher.poll()
    announce(comet, NEW)
    content = evaluation_file()
    comet.write(NEW, content[: len(content) // 2])
    watcher.poll()
    comet.clock.sleep(10)
    watcher.poll()
    assert len(comet.history("Comet")) == 1
    assert "Skipping" not in comet.printed()

    comet.write(NEW, content)
    watcher.poll()
    assert len(comet.history("Comet")) == 2


def test_without_a_lap_count_an_evaluation_waits_until_nothing_writes_to_it(comet: Scene) -> None:
    watcher = comet.watcher()
    watcher.poll()
    comet.write(NEW, evaluation_file())  # no parameters name it
    for _ in range(5):
        watcher.poll()
        comet.clock.sleep(SETTLE_S / 6)
    assert len(comet.history("Comet")) == 1

    comet.clock.sleep(SETTLE_S / 6)
    watcher.poll()
    assert len(comet.history("Comet")) == 2


def test_an_evaluation_synced_in_with_an_old_time_still_waits_until_nothing_changes_it(
        comet: Scene) -> None:
    watcher = comet.watcher()
    watcher.poll()
    comet.write(NEW, evaluation_file(1))  # no parameters give its lap count
    comet.age(NEW, HOUR_S)  # copied with the time it had elsewhere
    watcher.poll()
    comet.clock.sleep(SETTLE_S / 2)
    comet.write(NEW, evaluation_file(2))
    comet.age(NEW, HOUR_S)
    watcher.poll()
    comet.clock.sleep(SETTLE_S / 2)
    watcher.poll()
    assert len(comet.history("Comet")) == 1

    comet.clock.sleep(SETTLE_S / 2)
    watcher.poll()
    assert comet.service.history("Comet", None)[-1].laps_completed == 2


def test_a_file_that_stays_unreadable_is_reported_once_and_skipped(drifter: Scene) -> None:
    broken = drifter.evaluations()[0]
    broken.write_text('{"metrics": [{"trial": 1, "elapsed_ti')
    drifter.age(broken, HOUR_S)
    watcher = drifter.watcher()
    for _ in range(6):
        watcher.poll()
        drifter.clock.sleep(10)

    assert len(drifter.history("Drifter")) == 2, "the other evaluations are pushed"
    printed = drifter.printed()
    assert printed.count(f"Skipping metrics/{broken.name}: ") == 1
    assert "not valid JSON" in printed
    assert watcher.summary.skipped == [f"metrics/{broken.name}"]


def test_a_skipped_file_is_tried_again_once_it_changes(drifter: Scene) -> None:
    broken = drifter.evaluations()[0]
    good = broken.read_bytes()
    broken.write_text("{")
    watcher = drifter.watcher()
    for _ in range(3):
        watcher.poll()
    assert len(drifter.history("Drifter")) == 2

    drifter.write(f"metrics/{broken.name}", good)
    watcher.poll()
    drifter.clock.sleep(SETTLE_S)  # no parameters give its lap count: pushed once it is quiet
    watcher.poll()
    assert len(drifter.history("Drifter")) == 3


def test_an_evaluation_the_board_refuses_is_reported_and_skipped(tmp_path: Path) -> None:
    lefty = Scene(tmp_path, "lefty-ppo-drfc-cw")  # clockwise: not for the counter-clockwise board
    lefty.service.push(assemble(EXAMPLES / "speedy-ppo-console"))
    watcher = lefty.watcher(board_id="reInvent2019_track")
    watcher.poll()
    watcher.poll()

    assert len(lefty.board.pushed) == 1, "refused once, not tried again"
    assert "Skipping metrics/evaluation/evaluation-20240602140312.json: the board refused it" \
        in lefty.printed()


def test_the_same_run_is_never_pushed_twice_even_after_a_restart(drifter: Scene) -> None:
    drifter.watcher().poll()
    before = drifter.history("Drifter")

    again = drifter.watcher()
    again.poll()
    again.poll()

    assert drifter.history("Drifter") == before, "the board answered duplicate: nothing changed"
    assert again.summary.pushed == 0 and again.summary.already_on_board == 3
    assert drifter.printed().count("already on the board, nothing changed") == 3


def test_a_restarted_watch_does_not_push_an_evaluation_whose_training_went_on(
        drifter: Scene, tmp_path: Path) -> None:
    memory = tmp_path / "watched.json"
    drifter.watcher(memory=PushedEvaluations(memory, "board")).poll()
    before = drifter.history("Drifter")
    # Training goes on: its metrics grow, so each evaluation's record (and id) would change.
    for training in (drifter.folder / "metrics").rglob("TrainingMetrics*.json"):
        content = json.loads(training.read_text())
        content["metrics"].append(dict(content["metrics"][-1], episode=10_000))
        training.write_text(json.dumps(content))

    again = drifter.watcher(memory=PushedEvaluations(memory, "board"))
    again.poll()

    assert drifter.history("Drifter") == before
    assert again.summary.pushed == 0 and again.summary.already_on_board == 3
    assert drifter.printed().count("pushed by an earlier watch") == 3
    elsewhere = drifter.watcher(memory=PushedEvaluations(memory, "another board"))
    elsewhere.poll()
    assert elsewhere.summary.pushed == 3, "what was pushed is remembered per board"


# ---- an unreachable or busy board ------------------------------------------------------------


class UnreachableAtFirst(CountingBoard):
    def __init__(self, board: LeaderboardService, failures: int) -> None:
        super().__init__(board)
        self.failures = failures

    def push(self, record: Record, board_id: str | None) -> PushReceipt:
        if self.failures:
            self.failures -= 1
            raise domain.BoardUnreachable("cannot reach http://board.example: timed out")
        return super().push(record, board_id)


def test_an_unreachable_board_is_retried_with_growing_waits(comet: Scene) -> None:
    comet.watcher(UnreachableAtFirst(comet.service, failures=2)).poll()

    assert len(comet.history("Comet")) == 1
    assert comet.clock.sleeps == [1, 2]
    assert comet.printed().count("Cannot reach the board (cannot reach http://board.example") == 1


def test_retry_waits_stop_growing_at_a_minute(comet: Scene) -> None:
    comet.watcher(UnreachableAtFirst(comet.service, failures=9)).poll()

    assert len(comet.history("Comet")) == 1
    assert comet.clock.sleeps == [1, 2, 4, 8, 16, 32, MAX_RETRY_S, MAX_RETRY_S, MAX_RETRY_S]


def test_the_boards_cooldown_is_waited_out_and_evaluations_pushed_in_order(drifter: Scene) -> None:
    drifter.service.create_board(BoardSpec(board_id="club-night", title="Club night",
                                           track="reInvent2019", cooldown_s=300))
    watcher = drifter.watcher(board_id="club-night")
    watcher.poll()

    pushed = drifter.service.history("Drifter", "club-night")
    assert [item.best_lap_ms for item in pushed] == [10712, 10390, 9968], "in name order"
    assert drifter.clock.sleeps == [300, 300]
    resumes = datetime.fromtimestamp(drifter.clock.start + 300).strftime("%H:%M:%S")
    assert f"The board's cooldown is on: pushing metrics/EvaluationMetrics-20230518210841.json at " \
           f"{resumes}" in drifter.printed()


# ---- stopping ----------------------------------------------------------------------------------


class Refusing:
    def __init__(self, error: domain.DomainError) -> None:
        self.error = error

    def push(self, record: Record, board_id: str | None) -> PushReceipt:
        raise self.error


@pytest.mark.parametrize("error", [
    domain.BoardClosed("'club-night' is closed"),
    domain.SubmissionLimitReached("Comet has made all 3 submissions 'club-night' allows"),
    domain.BoardNotFound("no board 'club-nite'"),
    domain.NotAuthorized("the board refused an unsigned push"),
], ids=lambda e: type(e).__name__)
def test_a_board_that_takes_nothing_more_stops_the_watch(comet: Scene,
                                                         error: domain.DomainError) -> None:
    watcher = comet.watcher(Refusing(error))
    watcher.sleep = interrupt_after(3, comet.clock.sleep)  # a watch that goes on ends here
    with pytest.raises(type(error)):
        watcher.run()
    assert "Stopped watching" in comet.printed()
    assert comet.clock.sleeps == [], "no retry"


def interrupt_after(calls: int, then: Callable[[float], None]) -> Callable[[float], None]:
    def sleep(seconds: float) -> None:
        nonlocal calls
        calls -= 1
        if calls < 0:
            raise KeyboardInterrupt
        then(seconds)
    return sleep


def run_to_ctrl_c(watcher: Watcher) -> WatchSummary:
    try:
        return watcher.run()
    except KeyboardInterrupt:
        pytest.fail("Ctrl-C went through the watch")


def test_ctrl_c_stops_the_loop_with_a_summary(comet: Scene) -> None:
    watcher = comet.watcher()
    watcher.sleep = interrupt_after(2, comet.clock.sleep)
    announce(comet, NEW)
    comet.write(NEW, evaluation_file(1))  # 1 lap of 3: not complete

    summary = run_to_ctrl_c(watcher)

    assert summary.pushed == 1 and summary.not_complete == 1
    assert comet.printed().splitlines()[-1] == (
        f"Stopped watching {comet.folder}: 1 evaluation pushed, 1 not complete yet, not pushed.")


def test_ctrl_c_in_the_middle_of_a_push_stops_cleanly(comet: Scene) -> None:
    class Interrupted:
        def push(self, record: Record, board_id: str | None) -> PushReceipt:
            raise KeyboardInterrupt

    summary = run_to_ctrl_c(comet.watcher(Interrupted()))
    assert summary.pushed == 0
    assert "Stopped watching" in comet.printed()


# ---- the command -------------------------------------------------------------------------------


@pytest.fixture
def stop_at_first_sleep(monkeypatch: pytest.MonkeyPatch) -> None:
    """The watch's first pause is where Ctrl-C comes: a command that does not stop on its own
    then stops there instead of running on."""
    def interrupted(seconds: float) -> None:
        raise KeyboardInterrupt
    monkeypatch.setattr(time, "sleep", interrupted)


def invoke(*args: str | Path) -> tuple[int, str, str]:
    result = CliRunner().invoke(cli, [str(a) for a in args], catch_exceptions=False)
    return result.exit_code, result.stdout, result.stderr


@pytest.mark.usefixtures("stop_at_first_sleep")
def test_push_watch_pushes_then_stops_on_ctrl_c(drifter: Scene, tmp_path: Path) -> None:
    db = tmp_path / "cli.db"
    code, out, err = invoke("--db", db, "push", "--watch", drifter.folder)

    assert code == 0, err
    assert out.count("Drifter · drifter-ppo-drfc · reInvent2019_track") == 3
    assert out.rstrip().endswith(": 3 evaluations pushed.")
    assert "Traceback" not in out + err
    code, out, _ = invoke("--db", db, "history", "--format", "json")  # the racer is remembered
    assert code == 0 and len(json.loads(out)) == 3


@pytest.mark.usefixtures("stop_at_first_sleep")
def test_push_watch_stops_with_exit_1_when_the_board_closes(drifter: Scene, tmp_path: Path) -> None:
    db = tmp_path / "cli.db"
    service = LeaderboardService(SqliteStore(db))
    service.create_board(BoardSpec(board_id="club-night", title="Club night", track="reInvent2019"))
    service.close_board("club-night")

    code, out, err = invoke("--db", db, "push", "--watch", drifter.folder, "--board", "club-night")

    assert code == 1
    assert "'club-night' is closed" in err
    assert "Stopped watching" in out and "0 evaluations pushed" in out
    assert "Traceback" not in out + err


@pytest.mark.parametrize(("args", "message"), [
    (["--watch", "A", "B"], "--watch takes one training folder"),
    (["--watch", "--dry-run", "A"], "--watch and --dry-run do not go together"),
    (["--watch", "archive.tar.gz"], "--watch needs a training folder"),
    (["--interval", "5", "A"], "--interval and --only-new go with --watch"),
    (["--only-new", "A"], "--interval and --only-new go with --watch"),
    (["--watch", "--interval", "0", "A"], "Invalid value for '--interval'"),
])
def test_push_watch_options_are_checked(tmp_path: Path, args: list[str], message: str) -> None:
    for folder in ("A", "B"):
        (tmp_path / folder).mkdir()
    (tmp_path / "archive.tar.gz").write_bytes(b"")
    paths = [str(tmp_path / a) if a in ("A", "B", "archive.tar.gz") else a for a in args]

    code, _, err = invoke("--db", tmp_path / "cli.db", "push", *paths)

    assert code == 2
    assert message in err
