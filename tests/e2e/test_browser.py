"""The live board page in a real browser: Playwright driving Debian's Chromium against
`drboard serve`. Screenshots land in test-artifacts/ (kept by CI as the run's artefacts).

Skipped, with the reason, where Playwright or a Chromium is not installed (`.ci/run` installs
both).
"""

from __future__ import annotations

import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.e2e.test_serve import EXAMPLES, Served

sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright is not installed")
expect = sync_api.expect
CHROMIUM = os.environ.get("DRBOARD_CHROMIUM") or shutil.which("chromium") or shutil.which(
    "chromium-browser")
if CHROMIUM is None:
    pytest.skip("no Chromium on this machine (apt install chromium)", allow_module_level=True)

BOARD = "reInvent2019_track"
ARTIFACTS = Path(__file__).parents[2] / "test-artifacts"
RUNS = [run for run in EXAMPLES if not run.endswith("-cw")]


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with sync_api.sync_playwright() as playwright:
        chromium = playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        yield chromium
        chromium.close()


@pytest.fixture
def new_page(browser: Any) -> Iterator[Any]:
    """Opens pages of the given size in a browser context of this test's own, closed after it."""
    context = browser.new_context()

    def open_page(width: int, height: int) -> Any:
        page = context.new_page()
        page.set_viewport_size({"width": width, "height": height})
        return page

    yield open_page
    context.close()


def shot(page: Any, name: str) -> None:
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)


def racers(page: Any) -> list[str]:
    return page.eval_on_selector_all("tr[data-racer]", "rows => rows.map(r => r.dataset.racer)")


def test_a_push_updates_the_open_page_in_place_and_marks_the_row(served: Served,
                                                                  new_page: Any) -> None:
    served.drboard("push", RUNS[0])
    page = new_page(1920, 1080)
    statuses: list[int] = []
    page.on("response", lambda response: statuses.append(response.status)
            if response.url.endswith(f"/boards/{BOARD}/view") else None)
    page.goto(f"{served.url}/boards/{BOARD}/view")
    first = racers(page)
    assert len(first) == 1
    page.evaluate("window.stillTheSamePage = true")
    expect(page.locator("#live")).to_have_text("Live")
    page.wait_for_timeout(3500)  # at least one poll with If-None-Match
    assert 304 in statuses, statuses

    served.drboard("push", *RUNS[1:])
    expect(page.locator("tr[data-racer]")).to_have_count(len(RUNS), timeout=10_000)
    assert page.evaluate("window.stillTheSamePage") is True, "updated in place, not reloaded"
    shown = racers(page)
    assert page.locator("tr.fresh, tr.leader").count() == len(RUNS) - 1
    assert page.locator("tr.fresh td.move").first.inner_text() == "new"
    if shown[0] != first[0]:
        assert "leader" in (page.locator("tr[data-racer]").first.get_attribute("class") or "")
    shot(page, "live-board-1920x1080")


def test_a_new_leader_gets_a_banner_and_its_rank_movement(served: Served, new_page: Any) -> None:
    from tests.recordkit import make_record

    for n in range(20):
        served.post(f"/boards/{BOARD}/submissions",
                    make_record(f"Racer {n:02d}", [(9000 + 37 * n, 100)]).model_dump_json().encode())
    page = new_page(1920, 1080)
    page.goto(f"{served.url}/boards/{BOARD}/view?screen=1")
    expect(page.locator("#live")).to_contain_text("Live")
    page.evaluate("window.scrollTo(0, document.body.scrollHeight)")
    served.post(f"/boards/{BOARD}/submissions",
                make_record("Racer 19", [(8655, 100)]).model_dump_json().encode())
    banner = page.locator("#leader-banner")
    expect(banner).to_have_text("New leader — Racer 19 8.655 s", timeout=5000)
    leader = page.locator("tr[data-racer='Racer 19']")
    expect(leader).to_have_class(re.compile("leader"))
    assert leader.locator("td.move").inner_text() == "▲19"
    box = leader.bounding_box()
    assert box is not None and box["y"] >= 0 and box["y"] + box["height"] <= 1080, "in view"
    shot(page, "new-leader-1920x1080")
    page.wait_for_timeout(3000)
    expect(banner).to_be_visible()  # the room has several seconds to read it


def test_a_lost_connection_is_shown_within_5_seconds_and_its_return(served: Served,
                                                                    new_page: Any) -> None:
    served.drboard("push", RUNS[0])
    page = new_page(1920, 1080)
    page.goto(f"{served.url}/boards/{BOARD}/view?screen=1")
    expect(page.locator("#live")).to_contain_text("Live")
    page.wait_for_timeout(2500)  # the stream is up
    served.stop()
    lost = page.locator("#connection")
    expect(lost).to_contain_text("Connection lost", timeout=5000)
    assert "lost" in (lost.get_attribute("class") or "")
    shot(page, "connection-lost-1920x1080")


def test_a_page_opened_before_the_first_push_shows_the_board_once_it_exists(
        served: Served, new_page: Any) -> None:
    page = new_page(390, 844)
    page.goto(f"{served.url}/boards/{BOARD}/view")
    expect(page.locator("#live")).to_have_text("Waiting for the board's first push")
    served.drboard("push", RUNS[0])
    page.wait_for_selector("tr[data-racer]", timeout=10_000)
    assert racers(page)
    shot(page, "first-push-390x844")


LONG_RACER = "Maximilian the Unstoppable Racer of the Northern Leagues"


def push_long_name(served: Served) -> None:
    from tests.recordkit import make_record

    record = make_record(LONG_RACER, [(9141, 100), (9500, 100)])
    status, answer = served.post(f"/boards/{BOARD}/submissions", record.model_dump_json().encode())
    assert status == 201, answer


@pytest.mark.parametrize(("width", "height"), [(1920, 1080), (3840, 2160)])
def test_the_big_screen_fills_the_room_without_wrapped_numbers(served: Served, new_page: Any,
                                                               width: int, height: int) -> None:
    served.drboard("push", *RUNS)
    push_long_name(served)
    page = new_page(width, height)
    page.goto(f"{served.url}/boards/{BOARD}/view?screen=1")
    expect(page.locator("tr[data-racer]")).to_have_count(len(RUNS) + 1)
    expect(page.locator("figure.qr svg")).to_be_visible()
    wrapped = page.eval_on_selector_all("td.num", """cells => cells.filter((cell) => {
        const range = document.createRange();
        range.selectNodeContents(cell);
        const lines = new Set([...range.getClientRects()].map((r) => Math.round(r.top)));
        return lines.size > 1 || cell.scrollWidth > cell.clientWidth;
    }).map((cell) => cell.textContent)""")
    assert wrapped == []
    font = page.eval_on_selector("td.num", "cell => parseFloat(getComputedStyle(cell).fontSize)")
    assert font >= width / 100, f"{font}px text on a {width}px screen"
    smallest = page.evaluate("""Math.min(...[...document.querySelectorAll('main *')]
        .filter((el) => el.getClientRects().length && el.textContent.trim())
        .map((el) => parseFloat(getComputedStyle(el).fontSize)))""")
    assert smallest >= height / 100, f"{smallest}px text on a {height}px-high screen: every text scales"
    expect(page.locator("p.join strong")).to_be_visible()
    tall = page.eval_on_selector_all("tr[data-racer]", """rows => rows.filter((row) =>
        row.getBoundingClientRect().height > 2.2 * parseFloat(getComputedStyle(row).fontSize))
        .map((row) => [row.dataset.racer, row.getBoundingClientRect().height])""")
    assert tall == [], "one line a racer"
    table = page.eval_on_selector("table", "t => t.getBoundingClientRect().width")
    assert table >= 0.9 * width
    assert page.evaluate("document.documentElement.scrollWidth") <= width
    shot(page, f"big-screen-{width}x{height}")


def test_fifteen_racers_or_more_fit_the_1080p_screen(served: Served, new_page: Any) -> None:
    from tests.recordkit import make_record

    for n in range(30):
        served.post(f"/boards/{BOARD}/submissions", make_record(
            f"Racer {n:02d}", [(9000 + 37 * n, 100)], model=f"model-{n}").model_dump_json().encode())
    page = new_page(1920, 1080)
    page.goto(f"{served.url}/boards/{BOARD}/view?screen=1")
    expect(page.locator("tr[data-racer]")).to_have_count(30)
    seen = page.eval_on_selector_all("tr[data-racer]", """rows => rows.filter((row) => {
        const box = row.getBoundingClientRect();
        return box.top >= 0 && box.bottom <= innerHeight; }).length""")
    assert seen >= 15
    shot(page, "big-screen-30-racers-1920x1080")


PHONE_PAGES = [f"/boards/{BOARD}/view", f"/boards/{BOARD}/racers/Blaze/view",
               f"/boards/{BOARD}/compare/view?racer=Blaze&racer=Indy",
               f"/boards/{BOARD}/insights/view", "/", "/boards/nowhere/view",
               f"/boards/{BOARD}/racers/Nobody/view"]


@pytest.mark.parametrize("path", PHONE_PAGES)
def test_every_page_fits_a_phone_with_44_px_targets(served: Served, new_page: Any, path: str) -> None:
    served.drboard("push", *RUNS)
    push_long_name(served)
    page = new_page(390, 844)
    page.goto(served.url + path)
    page.wait_for_timeout(300)
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
    small = page.eval_on_selector_all("a, button, summary", """targets => targets
        .map((el) => [el.textContent.trim(), el.getBoundingClientRect()])
        .filter(([, box]) => box.width > 0 && (box.height < 44 || box.width < 44))
        .map(([text, box]) => `${text}: ${Math.round(box.width)}x${Math.round(box.height)}`)""")
    assert small == []
    name = path.strip("/").replace("/", "-").split("?")[0] or "index"
    shot(page, f"phone-{name}-390x844")


def test_the_racer_page_draws_the_laps_and_the_action_space(served: Served, new_page: Any) -> None:
    served.drboard("push", *RUNS)
    page = new_page(1280, 900)
    page.goto(f"{served.url}/boards/{BOARD}/view")
    page.locator("tr[data-racer] a").first.click()
    expect(page.locator("h1")).to_have_text("Blaze")
    charts = page.locator("figure.chart svg")
    assert charts.count() >= 3
    assert page.locator("figure.chart").first.locator("rect").count() == 5  # Blaze's five laps
    assert page.locator("figure.chart").nth(1).locator("circle").count() == 10  # ten actions
    card = page.locator("figure.card img")
    expect(card).to_have_js_property("complete", True)
    assert card.evaluate("img => [img.naturalWidth, img.naturalHeight]") == [1200, 630], "the PNG card"
    shot(page, "racer-page-1280x900")


def test_the_compare_page_marks_the_differences(served: Served, new_page: Any) -> None:
    served.drboard("push", *RUNS)
    page = new_page(1280, 900)
    page.goto(f"{served.url}/boards/{BOARD}/compare/view?racer=Blaze&racer=Indy")
    expect(page.locator("h1")).to_have_text("Blaze vs Indy")
    differing = page.locator("tr.differs th").all_inner_texts()
    assert any(text.lower().startswith("algorithm") for text in differing)
    assert page.locator("tr:not(.differs) th", has_text="sensors").count() == 1
    shot(page, "compare-1280x900")
    page.goto(f"{served.url}/boards/{BOARD}/insights/view?top=2")
    expect(page.locator("h1")).to_have_text("What the fast models share")
    shot(page, "insights-1280x900")


def test_the_big_screen_scrolls_through_a_long_board(served: Served, new_page: Any) -> None:
    from tests.recordkit import make_record

    for n in range(40):
        record = make_record(f"Racer {n:02d}", [(9000 + 37 * n, 100)])
        status, _ = served.post(f"/boards/{BOARD}/submissions", record.model_dump_json().encode())
        assert status == 201
    page = new_page(1920, 1080)
    page.goto(f"{served.url}/boards/{BOARD}/view?screen=1")
    expect(page.locator("tr[data-racer]")).to_have_count(40)
    assert page.evaluate("window.scrollY") == 0
    page.wait_for_timeout(6000)  # a pause at the top, then the page moves on by itself
    assert page.evaluate("window.scrollY") > 0


AXE = Path(__file__).parents[2] / "node_modules" / "axe-core" / "axe.min.js"


@pytest.mark.skipif(not AXE.is_file(), reason="axe-core not installed (npm install axe-core)")
@pytest.mark.parametrize("path", [
    f"/boards/{BOARD}/view", f"/boards/{BOARD}/view?screen=1", f"/boards/{BOARD}/racers/Blaze/view",
    f"/boards/{BOARD}/compare/view?racer=Blaze&racer=Indy", f"/boards/{BOARD}/insights/view", "/",
])
def test_the_pages_pass_an_accessibility_check(browser: Any, served: Served, path: str) -> None:
    """axe-core's WCAG 2 A and AA rules: contrast, headings, labels, names of images."""
    served.drboard("push", *RUNS)
    context = browser.new_context(bypass_csp=True)  # to inject axe-core; the page's own CSP is
    try:                                            # tested elsewhere
        page = context.new_page()
        page.goto(served.url + path)
        page.add_script_tag(path=str(AXE))
        result = page.evaluate("axe.run(document, {runOnly: ['wcag2a', 'wcag2aa']})")
        problems = [(v["id"], v["help"], [n["target"] for n in v["nodes"]][:3])
                    for v in result["violations"]]
        assert problems == []
    finally:
        context.close()
