"""`drboard serve` in its own process, driven by the real `drboard` command over HTTP."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import urllib.error
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.integration.dynamodb_local import DynamoDbLocal
from tests.tablekit import create_board_table

ROOT = Path(__file__).parents[2]
EXAMPLES = sorted(str(p) for p in (ROOT / "examples").iterdir() if p.is_dir())
DRBOARD = [sys.executable, "-m", "drboard_cli"]
READY = re.compile(r"on (http://\S+)")


class Served:
    def __init__(self, process: subprocess.Popen[str], url: str, env: dict[str, str]) -> None:
        self.process = process
        self.url = url
        self.env = env

    def drboard(self, *args: str, check: bool = True) -> subprocess.CompletedProcess[str]:
        result = subprocess.run([*DRBOARD, "--endpoint", self.url, *args], env=self.env,
                                capture_output=True, text=True, timeout=60)
        if check:
            assert result.returncode == 0, result.stderr
        return result

    def post(self, path: str, body: bytes) -> tuple[int, Any]:
        request = urllib.request.Request(self.url + path, data=body, method="POST",
                                         headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(request, timeout=30) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as error:
            return error.code, json.loads(error.read())

    def stop(self) -> int:
        self.process.send_signal(signal.SIGINT)  # what Ctrl-C sends
        return self.process.wait(timeout=30)


def _environment(tmp_path: Path) -> dict[str, str]:
    env = {key: value for key, value in os.environ.items()
           if not key.startswith(("DRBOARD_", "XDG_"))}
    env |= {"XDG_DATA_HOME": str(tmp_path / "data"), "XDG_CONFIG_HOME": str(tmp_path / "config"),
            "PYTHONUNBUFFERED": "1", "COLUMNS": "160"}
    return env


def _serve(tmp_path: Path, *options: str, db: Path | None = None) -> Served:
    env = _environment(tmp_path)
    board = ["--db", str(db)] if db else []
    process = subprocess.Popen([*DRBOARD, *board, "serve", "--port", "0", *options], env=env,
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    assert process.stdout is not None
    line = process.stdout.readline()
    match = READY.search(line)
    if not match:
        process.kill()
        pytest.fail(f"drboard serve did not start: {line!r}")
    assert match.group(1).startswith("http://127.0.0.1:"), "serve listens on loopback by default"
    return Served(process, match.group(1), env)


@pytest.fixture
def served_on_dynamodb(tmp_path: Path, dynamodb_local: DynamoDbLocal) -> Iterator[Served]:
    table = create_board_table(dynamodb_local.client(), f"e2e-{tmp_path.name}")
    served = _serve(tmp_path, "--table", table, "--endpoint-url", dynamodb_local.endpoint)
    yield served
    if served.process.poll() is None:
        served.stop()


def test_racers_push_pull_and_look_up_over_http(served_on_dynamodb: Served) -> None:
    served = served_on_dynamodb
    pushed = served.drboard("push", *EXAMPLES)
    assert pushed.stdout.count("new best") == len(EXAMPLES)

    standings = json.loads(served.drboard("pull", "--track", "reInvent2019", "--format", "json").stdout)
    entries = standings["entries"]
    assert entries[0]["rank"] == 1 and entries[0]["gap_ms"] == 0
    qualified = [e["time_ms"] for e in entries if e["qualified"]]
    assert qualified == sorted(qualified)
    leader = entries[0]["racer"]

    again = served.drboard("push", EXAMPLES[0])
    assert "already on the board" in again.stdout

    history = json.loads(served.drboard("history", "--racer", leader, "--format", "json").stdout)
    assert [item["is_best"] for item in history] == [True]

    shown = json.loads(served.drboard("show", leader, "--track", "reInvent2019", "--format",
                                      "json").stdout)
    assert shown["entry"]["rank"] == 1
    assert shown["record"]["design"]["action_space"]

    boards = json.loads(served.drboard("boards", "--format", "json").stdout)
    assert {b["board_id"] for b in boards} >= {"reInvent2019_track"}


def test_a_tampered_record_is_refused_with_field_detail(served_on_dynamodb: Served) -> None:
    served = served_on_dynamodb
    record = json.loads(subprocess.run([*DRBOARD, "assemble", EXAMPLES[0]], env=served.env,
                                       capture_output=True, text=True, check=True).stdout)
    record["evaluations"][0]["laps"][0]["time_ms"] -= 1000  # a faster lap than the files show
    status, answer = served.post(f"/boards/{record['track']}/submissions",
                                 json.dumps(record).encode())
    assert status == 422
    assert answer["detail"], answer
    listed = json.loads(served.drboard("boards", "--format", "json").stdout)
    assert listed == [], "nothing was written"


def test_an_unknown_racer_is_a_failure_not_a_crash(served_on_dynamodb: Served) -> None:
    served = served_on_dynamodb
    served.drboard("push", EXAMPLES[0])
    result = served.drboard("show", "Nobody", "--track", "reInvent2019", check=False)
    assert result.returncode == 1
    assert "Traceback" not in result.stderr


def test_ctrl_c_stops_serve_and_keeps_every_answered_push(tmp_path: Path) -> None:
    board = tmp_path / "event.db"
    served = _serve(tmp_path, db=board)
    served.drboard("push", *EXAMPLES[:3])
    assert served.stop() == 0
    local = subprocess.run([*DRBOARD, "--db", str(board), "pull", "--track", "reInvent2019",
                            "--format", "json"], env=served.env, capture_output=True, text=True,
                           check=True)
    assert len(json.loads(local.stdout)["entries"]) == 3
