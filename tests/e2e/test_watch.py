"""`drboard push --watch` in its own process, on a training folder that fills up as it watches."""

from __future__ import annotations

import os
import queue
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from drboard_assembler import assemble, evaluation_files
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

EXAMPLE = Path(__file__).parents[2] / "examples" / "comet-sac-drfc"
FIRST = "metrics/evaluation/evaluation-20240315101544.json"  # the one its parameters name
SECOND = "metrics/evaluation/evaluation-20240316090000.json"
DRBOARD = [sys.executable, "-m", "drboard_cli"]
TIMEOUT_S = 30.0


def _as_from_a_terminal() -> None:
    """Ctrl-C reaches the watch as it does from a terminal, even when the tests themselves run in
    the background of a shell, which starts them with SIGINT ignored (children inherit that)."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class Watch:
    """A running `drboard push --watch`, its output read line by line as it comes."""

    def __init__(self, tmp_path: Path, folder: Path) -> None:
        env = {key: value for key, value in os.environ.items()
               if not key.startswith(("DRBOARD_", "XDG_"))}
        env |= {"XDG_DATA_HOME": str(tmp_path / "data"),
                "XDG_CONFIG_HOME": str(tmp_path / "config"),
                "PYTHONUNBUFFERED": "1", "COLUMNS": "200"}
        self.db = tmp_path / "board.db"
        self.process = subprocess.Popen(
            [*DRBOARD, "--db", str(self.db), "push", "--watch", str(folder), "--interval", "0.2"],
            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            preexec_fn=_as_from_a_terminal)
        self.lines: queue.Queue[str] = queue.Queue()
        self.output: list[str] = []
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        assert self.process.stdout is not None
        for line in self.process.stdout:
            self.lines.put(line)

    def wait_for_line(self, starting: str) -> None:
        deadline = time.monotonic() + TIMEOUT_S
        while time.monotonic() < deadline:
            try:
                line = self.lines.get(timeout=0.1)
            except queue.Empty:
                continue
            self.output.append(line)
            if line.startswith(starting):
                return
        pytest.fail(f"no line starting {starting!r} in {self.output}")

    def stop(self, signal_number: int) -> tuple[int, str, str]:
        self.process.send_signal(signal_number)
        code = self.process.wait(timeout=TIMEOUT_S)
        self.reader.join(timeout=TIMEOUT_S)  # the rest of the output, up to the end
        while not self.lines.empty():
            self.output.append(self.lines.get())
        assert self.process.stderr is not None
        return code, "".join(self.output), self.process.stderr.read()

    def kill(self) -> None:
        if self.process.poll() is None:
            self.process.kill()
            self.process.wait()


@pytest.fixture
def training(tmp_path: Path) -> Path:
    folder = tmp_path / "training"
    folder.mkdir()
    return folder


@pytest.fixture
def watching(tmp_path: Path, training: Path) -> Iterator[Watch]:
    watch = Watch(tmp_path, training)
    try:
        watch.wait_for_line("Watching ")
        yield watch
    finally:
        watch.kill()


def wait_until(condition: Callable[[], bool], what: str) -> None:
    deadline = time.monotonic() + TIMEOUT_S
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"timed out waiting for {what}")
        time.sleep(0.1)


def add_evaluation(training: Path) -> None:
    """What DeepRacer-for-Cloud does for a new evaluation: parameters naming the metrics file
    first, then the metrics."""
    params = training / "evaluation_params.yaml"
    params.write_text(params.read_text().replace(Path(FIRST).name, Path(SECOND).name))
    (training / SECOND).write_bytes(
        (EXAMPLE / "metrics/evaluation/evaluation-20240315093012.json").read_bytes())


def test_watch_pushes_each_evaluation_as_it_appears_and_stops_on_ctrl_c(
        watching: Watch, training: Path) -> None:
    # The training's files, then its first evaluation.
    shutil.copytree(EXAMPLE, training, dirs_exist_ok=True,
                    ignore=lambda folder, names: [n for n in names if n == "evaluation"])
    shutil.copytree(EXAMPLE / "metrics/evaluation", training / "metrics/evaluation",
                    ignore=lambda folder, names: [n for n in names if "093012" in n])
    board = LeaderboardService(SqliteStore(watching.db))

    def pushed() -> int:
        return len(board.history("Comet", None))

    wait_until(lambda: pushed() == 1, "the first evaluation on the board")
    add_evaluation(training)
    wait_until(lambda: pushed() == 2, "the second evaluation on the board")
    # Ctrl-C once the racer sees the second receipt: a run committed to the board is printed a
    # moment later, after its rank is read back.
    watching.wait_for_line(f"{SECOND}: Comet")

    code, output, errors = watching.stop(signal.SIGINT)

    assert code == 0, errors
    assert "Traceback" not in output + errors
    assert f"{FIRST}: Comet" in output and f"{SECOND}: Comet" in output
    assert output.rstrip().endswith(": 2 evaluations pushed.")
    best_laps = sorted(item.best_lap_ms for item in board.history("Comet", None))
    assert best_laps == sorted(assemble(EXAMPLE, evaluation=name).best_run.best_lap_ms
                               for name in evaluation_files(EXAMPLE)), "each evaluation on its own"


def test_watch_stops_cleanly_on_sigterm(watching: Watch) -> None:
    code, output, errors = watching.stop(signal.SIGTERM)

    assert code == 0, errors
    assert "Traceback" not in output + errors
    assert output.rstrip().endswith(": 0 evaluations pushed.")
