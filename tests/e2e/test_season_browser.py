"""A season's page in a real browser: Playwright driving Debian's Chromium against `drboard
serve`, with a club's season of 30 racers over seven race nights and a final. The big screen at
1080p and 4K, a phone at 390 px, the desktop page, and axe-core's accessibility rules.
Screenshots land in test-artifacts/.

The season is made with the `drboard season` commands through the served board's HTTP API (so
they run against `serve` as a remote board would), and the runs are pushed to it over HTTP.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from tests.e2e.test_browser import AXE, CHROMIUM, browser, expect, new_page, shot
from tests.e2e.test_serve import Served
from tests.recordkit import make_record

__all__ = ["CHROMIUM", "browser", "new_page"]

SEASON = "club-2026"
NIGHTS = [f"club-2026-{month:02d}" for month in range(1, 8)]
FINAL = "club-2026-final"
RACERS = ["Ada", "Blaze", "Comet", "Drifter", "Indy", "Rookie", "Speedy", "Nova", "Orbit", "Pixel",
          "Quasar", "Rally", "Sprocket", "Turbo", "Vortex", "Widget", "Zephyr", "Apex", "Bolt",
          "Cinder", "Dash", "Ember", "Flux", "Glide", "Halo", "Ion", "Jet", "Kite", "Lumen",
          "Maximilian the Unstoppable of the Northern Leagues"]


def run_season(served: Served) -> None:
    """Seven nights, each with most of the club (not everyone comes every month), then the
    season: the best 5 of its 8 rounds count, the final counts double, and its top 8 qualify."""
    for n, board_id in enumerate([*NIGHTS, FINAL], start=1):
        title = "Club final 2026" if board_id == FINAL else f"Race night {n}"
        served.drboard("board", "create", board_id, "--title", title, "--track", "reInvent2019")
    for night, board_id in enumerate(NIGHTS):
        for index, racer in enumerate(RACERS):
            if (index + night) % 5 == 0:
                continue  # missed this night
            time_ms = 9_000 + 37 * ((index * 7 + night * 11) % len(RACERS))
            record = make_record(racer, [(time_ms, 100), (time_ms + 400, 100)], model=f"m{night}")
            status, answer = served.post(f"/boards/{board_id}/submissions",
                                         record.model_dump_json().encode())
            assert status == 201, answer
    served.drboard("season", "create", SEASON, "--title", "Club season 2026", "--best-of", "5",
                   "--participation", "2")
    for board_id in NIGHTS:
        served.drboard("season", "add-round", SEASON, board_id)
    served.drboard("season", "add-round", SEASON, FINAL, "--weight", "2", "--always-counts")
    served.drboard("season", "final", SEASON, FINAL, "--top", "8")


@pytest.fixture
def season(served: Served) -> Iterator[Served]:
    run_season(served)
    yield served


def rows(page: Any) -> list[str]:
    return page.eval_on_selector_all("tr[data-racer]", "rows => rows.map(r => r.dataset.racer)")


def test_the_desktop_page_shows_every_racer_and_round(season: Served, new_page: Any) -> None:
    page = new_page(1920, 1080)
    page.goto(f"{season.url}/seasons/{SEASON}/view")
    expect(page.locator("h1")).to_have_text("Club season 2026")
    assert len(rows(page)) == len(RACERS)
    assert page.locator("thead th.round").count() == len(NIGHTS) + 1
    assert page.locator("td.round.dropped").count() > 0, "rounds past the best 5 are struck"
    assert page.locator("tr.qualified").count() == 8
    page.locator("ol.rounds a").first.click()
    expect(page.locator("h1")).to_have_text("Race night 1")
    page.locator("p.rules a", has_text="Club season 2026").click()
    expect(page.locator("h1")).to_have_text("Club season 2026")
    page.goto(f"{season.url}/seasons/{SEASON}/view")
    shot(page, "season-1920x1080")


@pytest.mark.parametrize(("width", "height"), [(1920, 1080), (3840, 2160)])
def test_the_big_screen_is_read_across_a_room_a_page_at_a_time(season: Served, new_page: Any,
                                                                width: int, height: int) -> None:
    page = new_page(width, height)
    page.goto(f"{season.url}/seasons/{SEASON}/view?screen=1")
    assert len(rows(page)) == 15
    expect(page.locator("figure.qr svg")).to_be_visible()
    font = page.eval_on_selector("td.total", "cell => parseFloat(getComputedStyle(cell).fontSize)")
    assert font >= width / 100, f"{font}px text on a {width}px screen"
    cut = page.eval_on_selector_all("td.num", """cells => cells.filter((cell) => {
        const range = document.createRange();
        range.selectNodeContents(cell);
        const lines = new Set([...range.getClientRects()].map((r) => Math.round(r.top)));
        return lines.size > 1 || cell.scrollWidth > cell.clientWidth;
    }).map((cell) => cell.textContent)""")
    assert cut == [], "every number whole, on one line"
    fits = page.evaluate("[document.documentElement.scrollWidth, document.documentElement.scrollHeight]")
    assert fits[0] <= width and fits[1] <= height, f"{fits} on a {width}x{height} screen: no scrolling"
    shot(page, f"season-big-screen-{width}x{height}")
    if width == 1920:  # the next page of racers follows by itself
        page.wait_for_url("**/view?screen=1&part=2", timeout=25_000)
        assert len(rows(page)) == 15
        shot(page, "season-big-screen-1920x1080-part-2")


def test_the_phone_reads_the_season_without_sideways_scrolling(season: Served, new_page: Any) -> None:
    page = new_page(390, 844)
    page.goto(f"{season.url}/seasons/{SEASON}/view")
    assert len(rows(page)) == len(RACERS)
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
    small = page.eval_on_selector_all("a", "links => links.filter((a) => "
                                           "a.getBoundingClientRect().height < 44).length")
    assert small == 0, "every link a 44 px target"
    shot(page, "season-390x844")


@pytest.mark.skipif(not AXE.is_file(), reason="axe-core not installed (npm install axe-core)")
@pytest.mark.parametrize("path", [f"/seasons/{SEASON}/view", f"/seasons/{SEASON}/view?screen=1",
                                  "/seasons/view"])
def test_the_season_pages_pass_an_accessibility_check(browser: Any, season: Served, path: str) -> None:
    """axe-core's WCAG 2 A and AA rules: contrast, headings, labels, names of images."""
    context = browser.new_context(bypass_csp=True)
    try:
        page = context.new_page()
        page.goto(season.url + path)
        page.add_script_tag(path=str(AXE))
        result = page.evaluate("axe.run(document, {runOnly: ['wcag2a', 'wcag2aa']})")
        problems = [(v["id"], v["help"], [n["target"] for n in v["nodes"]][:3])
                    for v in result["violations"]]
        assert problems == []
    finally:
        context.close()
