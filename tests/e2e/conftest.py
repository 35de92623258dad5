"""End-to-end fixtures: the integration suite's dummy AWS settings and DynamoDB Local, a
`drboard serve` process on a board file (``served``), and a serve running in this process on a
thread (``server``)."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from drboard_cli.serve import BoardServer
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.e2e.test_serve import Served, _serve
from tests.integration.conftest import aws_dummy_settings, dynamodb_local

__all__ = ["aws_dummy_settings", "dynamodb_local", "served", "server"]


@pytest.fixture
def served(tmp_path: Path) -> Iterator[Served]:
    board = _serve(tmp_path, db=tmp_path / "event.db")
    yield board
    if board.process.poll() is None:
        board.stop()


@pytest.fixture
def server(tmp_path: Path) -> Iterator[BoardServer]:
    store = SqliteStore(tmp_path / "event.db")
    server = BoardServer(("127.0.0.1", 0), LeaderboardService(store))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()
    store.close()
