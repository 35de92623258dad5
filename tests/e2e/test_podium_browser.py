"""A season's podium in a real browser: its certificates printed (print media, A4 landscape),
its page on a 390 px phone, and its card; a racer's page with its card. Playwright driving
Debian's Chromium against `drboard serve` with the club's season of the season page's tests.
Screenshots land in test-artifacts/."""

from __future__ import annotations

import re
import struct
import urllib.request
from typing import Any

from tests.e2e.test_browser import ARTIFACTS, AXE, CHROMIUM, browser, expect, new_page, shot
from tests.e2e.test_season_browser import SEASON, season
from tests.e2e.test_serve import Served

__all__ = ["CHROMIUM", "browser", "new_page", "season"]

A4_LANDSCAPE_PX = (297 / 25.4 * 96, 210 / 25.4 * 96)  # CSS pixels: 96 to the inch


def test_the_podium_prints_one_certificate_to_an_a4_landscape_page(season: Served, new_page: Any) -> None:
    page = new_page(1280, 900)
    page.goto(f"{season.url}/seasons/{SEASON}/podium/view")
    certificates = page.locator("article.certificate")
    expect(certificates).to_have_count(3)
    assert page.locator("figure.card img").evaluate("img => img.naturalWidth") == 1200
    shot(page, "podium-1280x900")

    page.emulate_media(media="print")
    assert page.locator("figure.card").is_hidden() and page.locator("footer").is_hidden(), \
        "only the certificates print"
    for index in range(3):
        box = certificates.nth(index).bounding_box()
        assert box is not None
        assert abs(box["width"] - A4_LANDSCAPE_PX[0]) < 2 and abs(box["height"] - A4_LANDSCAPE_PX[1]) < 2
    names = certificates.locator("p.name")
    for index in range(3):  # a long name wraps inside its certificate rather than running off it
        assert names.nth(index).evaluate("el => el.scrollWidth <= el.clientWidth + 1")
    assert certificates.first.evaluate("el => getComputedStyle(el).breakAfter") == "page"
    shot(page, "podium-print")
    certificates.first.screenshot(path=str(ARTIFACTS / "podium-certificate-print.png"))
    pdf = page.pdf(prefer_css_page_size=True, print_background=True)
    ARTIFACTS.mkdir(exist_ok=True)
    (ARTIFACTS / "podium-certificates.pdf").write_bytes(pdf)
    assert re.findall(rb"/Count\s+(\d+)", pdf) == [b"3"], "three pages, a certificate each"
    boxes = re.findall(rb"/MediaBox\s*\[0 0 ([\d.]+) ([\d.]+)\]", pdf)
    assert len(boxes) == 3 and all(round(float(w)) == 842 and round(float(h)) == 595 for w, h in boxes), \
        "A4 landscape: 842 x 595 pt"


def test_the_podium_page_fits_a_phone(season: Served, new_page: Any) -> None:
    page = new_page(390, 844)
    page.goto(f"{season.url}/seasons/{SEASON}/podium/view")
    expect(page.locator("article.certificate")).to_have_count(3)
    assert page.evaluate("document.documentElement.scrollWidth") <= 390
    small = page.eval_on_selector_all("a", """targets => targets
        .map((el) => [el.textContent.trim(), el.getBoundingClientRect()])
        .filter(([, box]) => box.width > 0 && (box.height < 44 || box.width < 44))
        .map(([text, box]) => `${text}: ${Math.round(box.width)}x${Math.round(box.height)}`)""")
    assert small == []
    shot(page, "podium-390x844")


def test_the_season_card_is_a_1200_by_630_png(season: Served) -> None:
    with urllib.request.urlopen(f"{season.url}/seasons/{SEASON}/card.png") as answer:
        png = answer.read()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", png[16:24]) == (1200, 630)
    ARTIFACTS.mkdir(exist_ok=True)
    (ARTIFACTS / "card-season.png").write_bytes(png)


def test_the_podium_page_passes_an_accessibility_check(browser: Any, season: Served) -> None:
    if not AXE.is_file():
        import pytest

        pytest.skip("axe-core not installed (npm install axe-core)")
    context = browser.new_context(bypass_csp=True)
    try:
        page = context.new_page()
        page.goto(f"{season.url}/seasons/{SEASON}/podium/view")
        page.add_script_tag(path=str(AXE))
        result = page.evaluate("axe.run(document, {runOnly: ['wcag2a', 'wcag2aa']})")
        assert [(v["id"], v["help"]) for v in result["violations"]] == []
    finally:
        context.close()
