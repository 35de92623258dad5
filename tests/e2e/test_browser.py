"""The live board page in a real browser: Playwright driving Debian's Chromium against
`drboard serve`. Screenshots land in test-artifacts/ (kept by CI as the run's artefacts).

Skipped, with the reason, where Playwright or a Chromium is not installed (`.ci/run` installs
both).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.e2e.test_serve import EXAMPLES, Served, _serve

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
def served(tmp_path: Path) -> Iterator[Served]:
    board = _serve(tmp_path, db=tmp_path / "event.db")
    yield board
    if board.process.poll() is None:
        board.stop()


def shot(page: Any, name: str) -> None:
    ARTIFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTIFACTS / f"{name}.png"), full_page=True)


def racers(page: Any) -> list[str]:
    return page.eval_on_selector_all("tr[data-racer]", "rows => rows.map(r => r.dataset.racer)")


def test_a_push_updates_the_open_page_in_place_and_marks_the_row(browser: Any,
                                                                  served: Served) -> None:
    served.drboard("push", RUNS[0])
    page = browser.new_page(viewport={"width": 1920, "height": 1080})
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
    assert page.locator("tr.fresh").count() == len(RUNS) - 1
    if shown[0] != first[0]:
        assert "leader" in (page.locator("tr[data-racer]").first.get_attribute("class") or "")
    shot(page, "live-board-1920x1080")


def test_a_page_opened_before_the_first_push_shows_the_board_once_it_exists(
        browser: Any, served: Served) -> None:
    page = browser.new_page(viewport={"width": 390, "height": 844})
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
def test_the_big_screen_fills_the_room_without_wrapped_numbers(browser: Any, served: Served,
                                                               width: int, height: int) -> None:
    served.drboard("push", *RUNS)
    push_long_name(served)
    page = browser.new_page(viewport={"width": width, "height": height})
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
    table = page.eval_on_selector("table", "t => t.getBoundingClientRect().width")
    assert table >= 0.9 * width
    assert page.evaluate("document.documentElement.scrollWidth") <= width
    shot(page, f"big-screen-{width}x{height}")


def test_the_phone_sees_the_board_without_sideways_scrolling(browser: Any, served: Served) -> None:
    served.drboard("push", *RUNS)
    push_long_name(served)
    page = browser.new_page(viewport={"width": 390, "height": 844})
    page.goto(f"{served.url}/boards/{BOARD}/view")
    expect(page.locator("tr[data-racer]")).to_have_count(len(RUNS) + 1)
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
    shot(page, "board-390x844")
