"""Seasons over HTTP: organisers' routes, the public reads, the final's refusal, the season's
page and its big screen, and the board page's link to its season."""

from __future__ import annotations

import json
import re
from typing import Any

import pytest
from drboard_functions import web
from drboard_functions.models.seasons import SeasonList, SeasonStandings
from drboard_functions.routes import openapi_document

from tests.recordkit import make_record
from tests.unit.test_routes import SIGNED_IN_RACER, Client, app, client, service

__all__ = ["app", "client", "service"]

SEASON = "club-2026"


def body(response: dict[str, Any]) -> Any:
    return json.loads(response["body"])


@pytest.fixture
def season(client: Client) -> Client:
    """Three race nights and a final on Smile Speedway, and a season of the nights."""
    for board_id in ("jan", "feb", "mar", "final"):
        created = client.send("POST", "/boards", {"board_id": board_id, "title": f"{board_id.title()} night",
                                                  "track": "reInvent2019"})
        assert created["statusCode"] == 201, created["body"]
    for board_id, order in (("jan", ["Ada", "Bo", "Cy"]), ("feb", ["Bo", "Ada", "Cy", "Di"])):
        for n, racer in enumerate(order):
            pushed = client.push(make_record(racer, [(10_000 + 100 * n, 100)], model=board_id), board_id)
            assert pushed["statusCode"] == 201, pushed["body"]
    created = client.send("POST", "/seasons", {"season_id": SEASON, "title": "Club season 2026",
                                               "points": {"participation": 1}, "best_of": 2})
    assert created["statusCode"] == 201, created["body"]
    for board_id in ("jan", "feb"):
        assert client.send("PUT", f"/seasons/{SEASON}/rounds/{board_id}", {})["statusCode"] == 200
    return client


def standings(client: Client) -> list[tuple[int, str, float]]:
    answer = SeasonStandings.model_validate(body(client.get(f"/seasons/{SEASON}")))
    return [(s.rank, s.racer, s.points) for s in answer.standings]


def test_an_organiser_makes_a_season_that_everyone_reads(season: Client) -> None:
    assert standings(season) == [(1, "Ada", 26 + 19), (2, "Bo", 19 + 26), (3, "Cy", 16 + 16),
                                 (4, "Di", 13)]
    answer = body(season.get(f"/seasons/{SEASON}"))
    assert answer["season"]["tie_breaks"].startswith("Ties on points go to more round wins")
    assert [r["board_id"] for r in answer["season"]["rounds"]] == ["jan", "feb"]
    assert answer["standings"][0]["rounds"][0] == {"board_id": "jan", "rank": 1, "qualified": True,
                                                   "points": 26.0, "counted": True}
    listed = SeasonList.model_validate(body(season.get("/seasons")))
    assert [(s.season_id, s.status, s.rounds) for s in listed.seasons] == [(SEASON, "OPEN", 2)]
    from_a_browser = season.request("GET", f"/seasons/{SEASON}", headers={"origin": "https://club.example"},
                                    authorizer=None)
    assert "Access-Control-Allow-Origin" in from_a_browser["headers"], "reads are public"


def test_a_change_to_a_round_or_to_the_season_moves_the_standings(season: Client) -> None:
    season.send("PUT", f"/seasons/{SEASON}/rounds/feb", {"weight": 2})
    assert standings(season)[:2] == [(1, "Bo", 19 + 52), (2, "Ada", 26 + 38)]
    season.send("DELETE", "/boards/feb/racers/Bo")  # moderation on a round
    assert standings(season)[0] == (1, "Ada", 26 + 52)
    season.send("PATCH", f"/seasons/{SEASON}", {"points": {"positions": [3, 2, 1]}})
    assert standings(season)[0] == (1, "Ada", 3 + 6)
    season.send("DELETE", f"/seasons/{SEASON}/rounds/feb")
    assert [r[1] for r in standings(season)] == ["Ada", "Bo", "Cy"]


def test_the_final_refuses_a_racer_who_did_not_qualify_with_403(season: Client) -> None:
    final = season.send("PUT", f"/seasons/{SEASON}/final", {"board_id": "final", "top": 2})
    assert body(final)["season"]["final"]["qualifiers"] == ["Ada", "Bo"]
    refused = season.push(make_record("Cy", [(9_000, 100)], model="final"), "final")
    assert refused["statusCode"] == 403
    error = body(refused)
    assert error["error"] == "NotQualified" and "Ada, Bo" in error["message"]
    assert season.push(make_record("Bo", [(9_000, 100)], model="final"), "final")["statusCode"] == 201
    assert season.send("DELETE", f"/seasons/{SEASON}/final")["statusCode"] == 200
    assert season.push(make_record("Cy", [(9_000, 100)], model="final"), "final")["statusCode"] == 201


@pytest.mark.parametrize(("method", "path", "payload", "status", "error"), [
    ("POST", "/seasons", {"season_id": SEASON, "title": "Again"}, 409, "SeasonExists"),
    ("POST", "/seasons", {"season_id": "view", "title": "The page's id"}, 422, "InvalidQuery"),
    ("POST", "/seasons", {"season_id": "x", "title": "T", "points": {"positions": [1, 5]}}, 422,
     "InvalidQuery"),
    ("PATCH", f"/seasons/{SEASON}", {"title": None}, 400, "InvalidQuery"),
    ("PUT", f"/seasons/{SEASON}/rounds/nowhere", {}, 404, "BoardNotFound"),
    ("PUT", f"/seasons/{SEASON}/rounds/jan", {"weight": 0}, 422, "InvalidQuery"),
    ("PUT", "/seasons/nowhere/rounds/jan", {}, 404, "SeasonNotFound"),
    ("DELETE", f"/seasons/{SEASON}/rounds/mar", None, 404, "BoardNotFound"),
    ("PUT", f"/seasons/{SEASON}/final", {"board_id": "final", "top": 2, "from_round": "mar"}, 400,
     "InvalidQuery"),
    ("PUT", f"/seasons/{SEASON}/final", {"board_id": "reInvent2019_track", "top": 2}, 404,
     "BoardNotFound"),
    ("GET", "/seasons/nowhere", None, 404, "SeasonNotFound"),
])
def test_each_refusal_answers_its_status(season: Client, method: str, path: str, payload: Any,
                                          status: int, error: str) -> None:
    answer = season.send(method, path, payload) if method != "GET" else season.get(path)
    assert (answer["statusCode"], body(answer)["error"]) == (status, error), answer["body"]


def test_a_closed_season_refuses_changes_until_reopened(season: Client) -> None:
    closed = season.send("POST", f"/seasons/{SEASON}/close")
    assert body(closed)["season"]["status"] == "CLOSED"
    refused = season.send("PUT", f"/seasons/{SEASON}/rounds/mar", {})
    assert (refused["statusCode"], body(refused)["error"]) == (409, "SeasonLocked")
    assert season.send("POST", f"/seasons/{SEASON}/reopen")["statusCode"] == 200
    assert season.send("PUT", f"/seasons/{SEASON}/rounds/mar", {})["statusCode"] == 200


@pytest.mark.parametrize("authorizer", [SIGNED_IN_RACER, None])
def test_only_organisers_change_seasons(season: Client, authorizer: dict[str, Any] | None) -> None:
    for method, path, payload in [("POST", "/seasons", {"season_id": "mine", "title": "Mine"}),
                                  ("PATCH", f"/seasons/{SEASON}", {"title": "Mine"}),
                                  ("PUT", f"/seasons/{SEASON}/rounds/mar", {}),
                                  ("DELETE", f"/seasons/{SEASON}/rounds/jan", None),
                                  ("PUT", f"/seasons/{SEASON}/final", {"board_id": "final", "top": 1}),
                                  ("DELETE", f"/seasons/{SEASON}/final", None),
                                  ("POST", f"/seasons/{SEASON}/close", None),
                                  ("POST", f"/seasons/{SEASON}/reopen", None)]:
        answer = season.request(method, path, body=json.dumps(payload) if payload is not None else None,
                                authorizer=authorizer)
        assert answer["statusCode"] == 403, (method, path)
        assert "Access-Control-Allow-Origin" not in answer["headers"]
    assert [r[1] for r in standings(season)] == ["Ada", "Bo", "Cy", "Di"], "nothing changed"


def test_the_season_page_shows_the_standings_rounds_and_rules(season: Client) -> None:
    season.send("PUT", f"/seasons/{SEASON}/final", {"board_id": "final", "top": 2})
    race = season.push(make_record("Ada", [(12_000, 100)], model="mar"), "mar")
    assert race["statusCode"] == 201
    season.send("PUT", f"/seasons/{SEASON}/rounds/mar", {"weight": 2, "always_counts": True})
    page = season.get(f"/seasons/{SEASON}/view")
    assert page["statusCode"] == 200 and page["headers"]["Content-Type"].startswith("text/html")
    html = page["body"]
    assert "Club season 2026" in html
    assert "Points 25-18-15-12-10-8-6-4-2-1 for places 1 to 10, and 1 for taking part" in html
    assert "the best 2 of 3 rounds count · R3 counts ×2 and always counts" in html
    assert "Ties on points go to more round wins, then the better best finish" in html
    assert 'href="/boards/jan/view"' in html and 'href="/boards/final/view"' in html
    ada = _row(html, "Ada")
    assert "(qualifies for the final)" in ada
    assert ada.count("(dropped)") == 1, "Ada's three rounds: the best two count"
    assert "<script" not in html, "the page itself runs no script"
    assert "script-src" not in page["headers"]["Content-Security-Policy"]


def test_the_page_escapes_what_organisers_and_racers_typed(client: Client) -> None:
    client.send("POST", "/seasons", {"season_id": "evil", "title": "<script>alert(1)</script>",
                                     "description": "<img src=x onerror=alert(1)>"})
    html = client.get("/seasons/evil/view")["body"]
    assert "<script>alert" not in html and "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert "<img src=x" not in html


def test_the_big_screen_shows_a_page_of_racers_and_moves_on(client: Client) -> None:
    client.send("POST", "/boards", {"board_id": "night", "title": "Night", "track": "reInvent2019"})
    for n in range(20):
        client.push(make_record(f"Racer {n:02d}", [(9_000 + 50 * n, 100)]), "night")
    client.send("POST", "/seasons", {"season_id": SEASON, "title": "Club season 2026"})
    client.send("PUT", f"/seasons/{SEASON}/rounds/night", {})
    first = client.get(f"/seasons/{SEASON}/view", screen="1")
    html = first["body"]
    assert len(re.findall(r"<tr class=[^>]*data-racer=", html)) == 15
    assert 'data-next="/seasons/club-2026/view?screen=1&amp;part=2"' in html
    assert "<svg" in html, "a QR code of the page"
    policy = first["headers"]["Content-Security-Policy"]
    assert re.search(r"script-src 'sha256-[A-Za-z0-9+/=]+'", policy) and "unsafe" not in policy
    second = client.get(f"/seasons/{SEASON}/view", screen="1", part="2")["body"]
    assert len(re.findall(r"<tr class=[^>]*data-racer=", second)) == 5
    assert 'data-next="/seasons/club-2026/view?screen=1&amp;part=1"' in second
    assert "racers 16 to 20 of 20" in second


def test_the_seasons_page_lists_running_and_past_seasons(season: Client) -> None:
    season.send("POST", "/seasons", {"season_id": "club-2025", "title": "Club season 2025"})
    season.send("POST", "/seasons/club-2025/close")
    html = season.get("/seasons/view")["body"]
    assert re.search(r"Club season 2025</a> <span class=\"status closed\">Ended", html)
    assert re.search(r"Club season 2026</a> <span class=\"status open\">Running", html)


def test_a_round_and_a_final_link_to_their_season_from_their_board_page(season: Client) -> None:
    season.send("PUT", f"/seasons/{SEASON}/final", {"board_id": "final", "top": 2})
    round_page = season.get("/boards/jan/view")["body"]
    assert 'This board is a round of <a href="/seasons/club-2026/view">Club season 2026</a>' in round_page
    final_page = season.push(make_record("Ada", [(9_000, 100)], model="f"), "final")
    assert final_page["statusCode"] == 201
    assert "the final of <a href=\"/seasons/club-2026/view\">Club season 2026</a> (only its " \
           "qualifiers race)" in season.get("/boards/final/view")["body"]


def test_the_openapi_document_describes_the_season_routes() -> None:
    document = json.loads(openapi_document())
    paths = document["paths"]
    create = paths["/seasons"]["post"]
    assert create["requestBody"]["content"]["application/json"]["schema"]["$ref"].endswith("/SeasonSpec")
    assert {"201", "403", "409", "413", "422"} <= set(create["responses"])
    assert paths["/seasons/{season}"]["get"]["responses"]["200"]["content"]["application/json"][
        "schema"]["$ref"].endswith("/SeasonStandings")
    assert "security" not in paths["/seasons/{season}"]["get"]
    for path, method in [("/seasons/{season}/rounds/{board}", "put"), ("/seasons/{season}/final", "put"),
                         ("/seasons/{season}/close", "post")]:
        assert paths[path][method]["security"] == [{"sigv4": []}]
    assert "text/html" in paths["/seasons/{season}/view"]["get"]["responses"]["200"]["content"]


def _row(html: str, racer: str) -> str:
    match = re.search(rf'<tr class="[^"]*" data-racer="{racer}">.*?</tr>', html, re.S)
    assert match, racer
    return match.group(0)


def test_the_big_screens_qr_code_carries_the_address_racers_reach(season: Client) -> None:
    # `drboard serve` tells the pages its network address: a screen opened as localhost on the
    # serving laptop still gives phones an address they reach
    season.app.append_context(invite=lambda: web.Invite(endpoint="http://192.168.1.20:8000",
                                                        code="K7QM3XWD"))
    html = season.get(f"/seasons/{SEASON}/view", screen="1")["body"]
    assert 'aria-label="QR code of this page: http://192.168.1.20:8000/seasons/club-2026/view"' in html
