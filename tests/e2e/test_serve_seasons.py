"""Seasons on `drboard serve`, of the embedded board and of a DynamoDB Local table: the
`drboard season` commands over HTTP, a final that refuses a racer who did not qualify, the
season's page; and the organiser's season routes refused to every other computer."""

from __future__ import annotations

import json
import urllib.request
from typing import Any

import pytest
from drboard_cli.serve import BoardServer

from tests.e2e.test_serve import EXAMPLES, Served, _from, served_board, served_on_dynamodb

__all__ = ["served_board", "served_on_dynamodb"]

RUNS = {run.rsplit("/", 1)[-1].split("-", 1)[0]: run for run in EXAMPLES if not run.endswith("-cw")}


def test_an_organiser_runs_a_season_over_http(served_board: Served) -> None:
    served = served_board
    for board_id, title in (("night-1", "Night 1"), ("night-2", "Night 2"), ("final", "Final")):
        served.drboard("board", "create", board_id, "--title", title, "--track", "reInvent2019")
    served.drboard("push", RUNS["blaze"], RUNS["indy"], RUNS["comet"], "--board", "night-1")
    served.drboard("push", RUNS["indy"], RUNS["speedy"], "--board", "night-2")
    served.drboard("season", "create", "club", "--title", "Club season", "--participation", "1")
    for board_id in ("night-1", "night-2"):
        served.drboard("season", "add-round", "club", board_id)
    served.drboard("season", "final", "club", "final", "--top", "2")

    standings = json.loads(served.drboard("season", "standings", "club", "--format", "json").stdout)
    assert [(s["racer"], s["points"], s["qualified_for_final"]) for s in standings["standings"]] == [
        ("Indy", 19 + 26, True), ("Blaze", 26, True), ("Speedy", 19, False), ("Comet", 16, False)]

    refused = served.drboard("push", RUNS["speedy"], "--board", "final", check=False)
    assert refused.returncode == 1 and "did not qualify" in refused.stderr
    assert "Indy, Blaze" in refused.stderr
    served.drboard("push", RUNS["blaze"], "--board", "final")

    served.drboard("board", "remove-entry", "night-1", "Blaze")  # moderation moves the season
    after = json.loads(served.drboard("season", "standings", "club", "--format", "json").stdout)
    assert [s["racer"] for s in after["standings"]] == ["Indy", "Comet", "Speedy"]
    with urllib.request.urlopen(f"{served.url}/seasons/club/view", timeout=30) as page:
        html = page.read().decode()
    assert "Club season" in html and 'href="/boards/night-2/view"' in html
    listed = json.loads(served.drboard("season", "list", "--format", "json").stdout)
    assert [s["season_id"] for s in listed] == ["club"]


@pytest.mark.parametrize(("method", "path", "body"), [
    ("POST", "/seasons", {"season_id": "mine", "title": "Mine"}),
    ("PATCH", "/seasons/club", {"title": "Mine"}),
    ("PUT", "/seasons/club/rounds/club-night", {}),
    ("DELETE", "/seasons/club/rounds/club-night", None),
    ("PUT", "/seasons/club/final", {"board_id": "club-night", "top": 1}),
    ("DELETE", "/seasons/club/final", None),
    ("POST", "/seasons/club/close", None),
    ("POST", "/seasons/club/reopen", None),
])
def test_another_computer_gets_403_for_every_season_change(
        server: BoardServer, method: str, path: str, body: dict[str, Any] | None) -> None:
    assert _from(server, "127.0.0.1", "POST", "/boards",
                 {"board_id": "club-night", "title": "Club night", "track": "reInvent2019"})[0] == 201
    assert _from(server, "127.0.0.1", "POST", "/seasons", {"season_id": "club", "title": "Club"})[0] == 201
    status, answer = _from(server, "192.168.1.20", method, path, body)
    assert (status, answer["error"]) == (403, "NotAuthorized")
    assert _from(server, "192.168.1.20", "GET", "/seasons/club", None)[0] == 200, "reads are public"
    assert server.service.season("club").season.title == "Club"
