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
    out = io.BytesIO()

    rows = write_laps(HttpBoard(f"http://{host}:{port}"), TRACK, out)

    text = out.getvalue().decode()
    assert rows == 10 and text.count("board_id,racer,") == 1, "one header row for the whole file"
    read = list(csv.DictReader(io.StringIO(text)))
    assert sorted({r["racer"] for r in read}) == [f"Racer{n}" for n in range(5)]
    assert {r["time_s"] for r in read if r["racer"] == "Racer3"} == {"10.003", "12"}


def test_serve_draws_the_racers_card_and_names_it_at_its_own_address(server: BoardServer) -> None:
    import re
    import struct
    import urllib.request

    server.service.push(make_record("Ada", [(9120, 100)], model="ada-v7"))
    host, port = server.server_address
    base = f"http://{host}:{port}"
    with urllib.request.urlopen(f"{base}/boards/{TRACK}/racers/Ada/card.png") as answer:
        assert answer.headers["Content-Type"] == "image/png"
        png = answer.read()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", png[16:24]) == (1200, 630)
    with urllib.request.urlopen(f"{base}/boards/{TRACK}/racers/Ada/view") as answer:
        page = answer.read().decode()
    (image,) = re.findall(r'<meta property="og:image" content="([^"]+)"', page)
    assert image == f"{base}/boards/{TRACK}/racers/Ada/card.png", "an absolute URL, serve's own"
    assert HttpBoard(base).racer_card(TRACK, "Ada", "png") == png, "`drboard card` saves the same"
