"""Results over HTTP: `drboard --endpoint URL export --laps` follows the board's pages of laps
into one CSV file."""

from __future__ import annotations

import csv
import io

import pytest
from drboard_cli.remote import HttpBoard
from drboard_cli.serve import BoardServer
from drboard_cli.transfer import write_laps
from drboard_functions.service import results as results_room

from tests.recordkit import make_record

TRACK = "reInvent2019_track"


def test_export_laps_over_http_follows_every_page(server: BoardServer,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    for n in range(5):
        server.service.push(make_record(f"Racer{n}", [(10000 + n, 100), (12000, 60)]))
    monkeypatch.setattr(results_room, "LAPS_PAGE", 2)  # three pages
    host, port = server.server_address
    out = io.StringIO()

    rows = write_laps(HttpBoard(f"http://{host}:{port}"), TRACK, out)

    text = out.getvalue()
    assert rows == 10 and text.count("board_id,racer,") == 1, "one header row for the whole file"
    read = list(csv.DictReader(io.StringIO(text)))
    assert sorted({r["racer"] for r in read}) == [f"Racer{n}" for n in range(5)]
    assert {r["time_s"] for r in read if r["racer"] == "Racer3"} == {"10.003", "12"}
