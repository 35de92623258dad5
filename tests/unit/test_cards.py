"""Result cards: what a racer's card says (board, rank, time, gap, model), names fitted to their
box with the font's own widths, the PNG drawn from the SVG at 1200×630, the card routes, and the
racer page's Open Graph and Twitter meta naming the card with absolute URLs."""

from __future__ import annotations

import base64
import html
import json
import re
import struct
import xml.etree.ElementTree as ElementTree
from collections.abc import Iterator
from pathlib import Path

import pytest
from drboard_functions.cards import metrics, racer_svg
from drboard_functions.cards.png import render
from drboard_functions.cards.widths import widths_table
from drboard_functions.models.requests import BoardSpec
from drboard_functions.routes import build_app, card_router, pull_router
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record
from tests.unit.test_routes import Client, Clock

FONTS = Path(__file__).parents[2] / "functions" / "drboard_functions" / "cards" / "fonts"
SVG = "{http://www.w3.org/2000/svg}"
LONG = "Maximilian the Unstoppable Racer of the Northern Leagues and Beyond"


@pytest.fixture
def service() -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    board = LeaderboardService(store, clock=Clock())
    board.create_board(BoardSpec(board_id="club-night", title="Club night <December>",
                                 track="reInvent2019"))
    board.push(make_record("Blaze", [(8655, 100)], model="blaze-ppo"), "club-night")
    board.push(make_record("Ada", [(9120, 100)], model="ada-v7"), "club-night")
    board.push(make_record("Indy", [(9900, 100)], model="indy & co"), "club-night")
    yield board
    store.close()


@pytest.fixture
def client(service: LeaderboardService) -> Client:
    return Client(build_app(pull_router, card_router), service)


def texts(svg: str) -> list[str]:
    """The card's lines of text, as a viewer reads them (the SVG parses as XML)."""
    return [element.text or "" for element in ElementTree.fromstring(svg).iter(f"{SVG}text")]


def png_size(png: bytes) -> tuple[int, int]:
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and png[12:16] == b"IHDR", "a PNG"
    width, height = struct.unpack(">II", png[16:24])
    return width, height


def card_of(client: Client, racer: str, kind: str = "svg") -> dict[str, object]:
    answer = client.get(f"/boards/club-night/racers/{racer}/card.{kind}")
    assert answer["statusCode"] == 200, answer["body"]
    return answer


def test_a_racers_card_says_the_board_rank_time_gap_and_model(client: Client) -> None:
    svg = str(card_of(client, "Ada")["body"])
    lines = texts(svg)
    assert "Club night <December>" in lines, "the board, escaped in the SVG"
    assert "&lt;December&gt;" in svg
    assert {"#2", "of 3", "Ada", "ada-v7", "9.120 s", "+0.465 s to the leader"} <= set(lines)
    assert ElementTree.fromstring(svg).get("width") == "1200"
    assert ElementTree.fromstring(svg).get("height") == "630"


def test_the_leaders_card_says_the_lead_and_a_non_qualifier_its_completion(
        service: LeaderboardService, client: Client) -> None:
    assert {"#1", "8.655 s", "leads by 0.465 s"} <= set(texts(str(card_of(client, "Blaze")["body"])))
    service.push(make_record("Rookie", [(20000, 42.5)], model="rookie"), "club-night")
    rookie = texts(str(card_of(client, "Rookie")["body"]))
    assert {"#4", "42.5 % done", "BEST COMPLETION"} <= set(rookie)
    assert not any("leader" in line for line in rookie)


def test_the_png_is_drawn_from_the_svg_at_1200_by_630(client: Client) -> None:
    answer = card_of(client, "Ada", "png")
    assert answer["headers"]["Content-Type"] == "image/png"  # type: ignore[index]
    assert answer["isBase64Encoded"] is True
    assert png_size(base64.b64decode(str(answer["body"]))) == (1200, 630)
    svg_tag = card_of(client, "Ada")["headers"]["ETag"]  # type: ignore[index]
    assert answer["headers"]["ETag"] != svg_tag  # type: ignore[index]


def test_a_card_the_client_holds_is_answered_304_before_it_is_drawn(
        service: LeaderboardService, client: Client) -> None:
    first = card_of(client, "Ada", "png")
    etag = first["headers"]["ETag"]  # type: ignore[index]
    held = client.request("GET", "/boards/club-night/racers/Ada/card.png", headers={"if-none-match": etag})
    assert held["statusCode"] == 304 and not held["body"]
    service.push(make_record("Zed", [(9000, 100)], model="zed"), "club-night")  # Ada drops to #3
    moved = client.request("GET", "/boards/club-night/racers/Ada/card.png", headers={"if-none-match": etag})
    assert moved["statusCode"] == 200, "the card changed with the board"


def test_an_unknown_racer_or_board_has_no_card(client: Client) -> None:
    assert client.get("/boards/club-night/racers/Nobody/card.png")["statusCode"] == 404
    assert client.get("/boards/nowhere/racers/Ada/card.svg")["statusCode"] == 404


def test_a_long_name_is_drawn_smaller_then_cut_to_fit_its_box() -> None:
    box = 820.0
    fitted = metrics.fit(LONG, box, 72, 34, "bold")
    assert fitted.size == 34 and fitted.text.endswith("…") and fitted.text.startswith("Maximilian the")
    assert metrics.width(fitted.text, fitted.size, "bold") <= box
    shorter = metrics.fit("Maximilian the Unstoppable", box, 72, 34, "bold")
    assert shorter.text == "Maximilian the Unstoppable" and 34 < shorter.size < 72
    assert metrics.width(shorter.text, shorter.size, "bold") <= box
    assert metrics.fit("Ada", box, 72, 34, "bold").size == 72


def test_widths_are_the_fonts_own() -> None:
    # Liberation Sans's advance widths (2048 units to the em): "W" is wider than "i", bold wider
    assert metrics.width("W", 2048) == 1933 and metrics.width("i", 2048) == 455
    assert metrics.width("Ada", 100, "bold") > metrics.width("Ada", 100)
    assert metrics.width("", 100) == 0


def test_the_committed_widths_are_read_from_the_fonts() -> None:
    committed = json.loads((FONTS / "widths.json").read_text("utf-8"))
    assert committed == widths_table(), (
        "fonts/widths.json is out of date with the fonts: run `python -m "
        "drboard_functions.cards.widths > functions/drboard_functions/cards/fonts/widths.json`")


def test_the_fonts_ship_with_their_licence() -> None:
    licence = (FONTS / "LICENSE").read_text("utf-8")
    assert "SIL OPEN FONT LICENSE Version 1.1" in licence and "Reserved Font Name Liberation" in licence
    assert sorted(p.name for p in FONTS.glob("*.ttf")) == ["LiberationSans-Bold.ttf",
                                                           "LiberationSans-Regular.ttf"]


def test_a_script_the_font_lacks_is_held_to_its_measured_width(service: LeaderboardService,
                                                               client: Client) -> None:
    assert metrics.covers("Łukasz Ωμέγα Жук") and not metrics.covers("太郎")
    service.push(make_record("Taro 太郎", [(9500, 100)], model="taro"), "club-night")
    svg = str(card_of(client, "Taro%20%E5%A4%AA%E9%83%8E")["body"])
    (name,) = [e for e in ElementTree.fromstring(svg).iter(f"{SVG}text") if e.text == "Taro 太郎"]
    assert name.get("lengthAdjust") == "spacingAndGlyphs"
    assert float(name.get("textLength") or 0) == pytest.approx(
        metrics.width("Taro 太郎", float(name.get("font-size") or 0), "bold"), abs=0.1)
    assert png_size(render(svg)) == (1200, 630)
    assert all(e.get("textLength") is None for e in ElementTree.fromstring(svg).iter(f"{SVG}text")
               if e.text != "Taro 太郎"), "covered text is drawn as the font spaces it"


def test_the_racer_page_names_its_card_in_open_graph_and_twitter_meta(client: Client) -> None:
    page = client.request("GET", "/boards/club-night/racers/Ada/view", headers={
        "host": "abc123.execute-api.eu-west-1.amazonaws.com", "x-forwarded-proto": "https"})
    assert page["statusCode"] == 200
    meta = {name: html.unescape(value) for name, value in
            re.findall(r'<meta (?:property|name)="([^"]+)" content="([^"]*)"', page["body"])}
    origin = "https://abc123.execute-api.eu-west-1.amazonaws.com"
    assert meta["og:image"] == origin + "/boards/club-night/racers/Ada/card.png"
    assert meta["twitter:image"] == meta["og:image"]
    assert (meta["og:image:width"], meta["og:image:height"]) == ("1200", "630")
    assert meta["twitter:card"] == "summary_large_image"
    assert meta["og:url"] == origin + "/boards/club-night/racers/Ada/view"
    assert meta["og:title"] == "Ada: #2 of 3 on Club night <December>"
    assert meta["og:description"].startswith("9.120 s, +0.465 s to the leader with ada-v7")
    assert '<img src="/boards/club-night/racers/Ada/card.png"' in page["body"], "the page shows it"


def test_racer_svg_escapes_what_racers_write() -> None:
    from drboard_functions.cards import RacerCard

    card = RacerCard(board_title="a & b", subtitle="s", rank=1, field=1, racer="<script>x</script>",
                     model_name='m"1', result="9.000 s", result_label="best lap", gap="", leads=True,
                     date="2026-12-01")
    svg = racer_svg(card)
    assert "<script>" not in svg and "&lt;script&gt;" in svg
    assert {"a & b", "<script>x</script>", 'm"1'} <= set(texts(svg))


def test_drboard_card_saves_the_racers_card_from_the_embedded_board(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from click.testing import CliRunner
    from drboard_cli.main import cli

    db = tmp_path / "board.db"
    store = SqliteStore(db)
    LeaderboardService(store).push(make_record("Ada", [(9120, 100)], model="ada-v7"))
    store.close()
    monkeypatch.chdir(tmp_path)
    runner = CliRunner()
    saved = runner.invoke(cli, ["--db", str(db), "card", "Ada", "--track", "reInvent2019"])
    assert saved.exit_code == 0, saved.output
    assert png_size((tmp_path / "Ada-reInvent2019_track.png").read_bytes()) == (1200, 630)
    source = runner.invoke(cli, ["--db", str(db), "card", "Ada", "--track", "reInvent2019",
                                 "--format", "svg", "-o", "ada.svg"])
    assert source.exit_code == 0, source.output
    assert {"Ada", "ada-v7", "9.120 s", "#1"} <= set(texts((tmp_path / "ada.svg").read_text("utf-8")))
    missing = runner.invoke(cli, ["--db", str(db), "card", "Nobody", "--track", "reInvent2019"])
    assert missing.exit_code == 1 and "Nobody" in missing.output


def test_drboard_season_card_saves_the_podium_card(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    from click.testing import CliRunner
    from drboard_cli.main import cli

    db = tmp_path / "season.db"
    store = SqliteStore(db)
    local = LeaderboardService(store)
    from drboard_functions.models.seasons import SeasonSpec

    local.create_board(BoardSpec(board_id="night", title="Night", track="reInvent2019"))
    local.push(make_record("Ada", [(9120, 100)], model="ada-v7"), "night")
    local.create_season(SeasonSpec(season_id="club", title="Club season"))
    local.add_round("club", "night")
    store.close()
    monkeypatch.chdir(tmp_path)
    saved = CliRunner().invoke(cli, ["--db", str(db), "season", "card", "club"])
    assert saved.exit_code == 0, saved.output
    assert png_size((tmp_path / "club-podium.png").read_bytes()) == (1200, 630)


# ---- a season's podium: the card, the page's meta, the certificates ------------------------------


@pytest.fixture
def season(service: LeaderboardService) -> LeaderboardService:
    from drboard_functions.models.seasons import SeasonSpec

    service.create_board(BoardSpec(board_id="second-night", title="Second night", track="reInvent2019"))
    service.push(make_record("Ada", [(8800, 100)], model="ada-v8"), "second-night")
    service.push(make_record("Indy", [(9300, 100)], model="indy"), "second-night")
    service.create_season(SeasonSpec(season_id="club-2027", title="Club season 2027"))
    service.add_round("club-2027", "club-night")
    service.add_round("club-2027", "second-night")
    service.close_board("club-night")
    return service


def test_a_seasons_podium_card_says_its_first_three_with_points_wins_and_gaps(
        season: LeaderboardService, client: Client) -> None:
    answer = client.get("/seasons/club-2027/card.svg")
    assert answer["statusCode"] == 200, answer["body"]
    lines = texts(str(answer["body"]))
    # Ada: 18 + 25 = 43, Blaze: 25 + 0 = 25, Indy: 15 + 18 = 33 (the league's points)
    assert lines[:2] == ["Club season 2027", "Season podium · 2 of 2 rounds with results"]
    assert {"1", "Ada", "43 pts", "1 win · 2 rounds raced"} <= set(lines)
    assert {"2", "Indy", "33 pts", "−10 pts", "best finish 2nd · 2 rounds raced"} <= set(lines)
    assert {"3", "Blaze", "25 pts", "−18 pts", "1 win · 1 round raced"} <= set(lines)
    png = client.get("/seasons/club-2027/card.png")
    assert png_size(base64.b64decode(str(png["body"]))) == (1200, 630)
    assert client.get("/seasons/nowhere/card.png")["statusCode"] == 404


def test_a_season_with_no_points_yet_still_has_a_card(service: LeaderboardService, client: Client) -> None:
    from drboard_functions.models.seasons import SeasonSpec

    service.create_season(SeasonSpec(season_id="empty", title="Empty season"))
    lines = texts(str(client.get("/seasons/empty/card.svg")["body"]))
    assert "No points yet: the podium comes with the first round's results." in lines


def meta_of(page: str) -> dict[str, str]:
    return {name: html.unescape(value) for name, value in
            re.findall(r'<meta (?:property|name)="([^"]+)" content="([^"]*)"', page)}


def test_the_season_page_and_its_podium_page_name_the_podium_card(season: LeaderboardService,
                                                                  client: Client) -> None:
    headers = {"host": "abc123.execute-api.eu-west-1.amazonaws.com", "x-forwarded-proto": "https"}
    origin = "https://abc123.execute-api.eu-west-1.amazonaws.com"
    for path in ("/seasons/club-2027/view", "/seasons/club-2027/podium/view"):
        page = client.request("GET", path, headers=headers)
        assert page["statusCode"] == 200, page["body"]
        meta = meta_of(page["body"])
        assert meta["og:image"] == meta["twitter:image"] == origin + "/seasons/club-2027/card.png"
        assert (meta["og:image:width"], meta["og:image:height"]) == ("1200", "630")
        assert meta["twitter:card"] == "summary_large_image"
        assert meta["og:url"] == origin + path
        assert meta["og:title"] == "Club season 2027: standings"
        assert meta["og:description"] == "1st Ada (43 pts), 2nd Indy (33 pts), 3rd Blaze (25 pts) · 2 rounds."
    assert '<a href="/seasons/club-2027/podium/view">Podium and certificates</a>' in client.request(
        "GET", "/seasons/club-2027/view", headers=headers)["body"]


def test_the_podium_page_has_a_certificate_for_each_of_the_first_three(season: LeaderboardService,
                                                                       client: Client) -> None:
    season.close_season("club-2027")
    page = client.get("/seasons/club-2027/podium/view")["body"]
    certificates = re.findall(r'<article class="certificate (\w+)" aria-label="Certificate: ([^"]+)">', page)
    assert certificates == [("gold", "First place, Ada"), ("silver", "Second place, Indy"),
                            ("bronze", "Third place, Blaze")]
    assert '<p class="result">43 points</p>' in page and "in Club season 2027" in page
    assert meta_of(page)["og:title"] == "Club season 2027: final standings"
    assert client.get("/seasons/nowhere/podium/view")["statusCode"] == 404
