"""The web pages as a projector, a phone and a screen reader meet them: contrast, status, window,
rules, how to push, the big screen's QR code."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest
from drboard_assembler.record import RaceType
from drboard_functions import web
from drboard_functions.models.domain import BoardStatus, TimingMethod
from drboard_functions.models.views import BoardPage, BoardView

NOW = datetime(2026, 12, 1, 18, 0, tzinfo=UTC)


def contrast(foreground: str, background: str) -> float:
    """WCAG 2 contrast ratio of two #rrggbb colours."""
    def luminance(colour: str) -> float:
        channels = [int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)]
        linear = [c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4 for c in channels]
        return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]
    light, dark = sorted((luminance(foreground), luminance(background)), reverse=True)
    return (light + 0.05) / (dark + 0.05)


#: Every text colour of the pages, with each background it sits on.
TEXT_ON_BACKGROUND = (
    [(colour, web.BACKGROUND) for colour in (web.TEXT, web.MUTED, web.LINK)]
    + [(web.TEXT, glow) for glow in web.ROW_GLOW.values()]
    + [(web.MUTED, glow) for glow in web.ROW_GLOW.values()]
    + [(text, fill) for fill, text in web.MEDALS.values()]
    + [(text, fill) for fill, text in web.STATUS_COLOURS.values()]
)


@pytest.mark.parametrize(("foreground", "background"), TEXT_ON_BACKGROUND)
def test_every_text_colour_reads_at_4_5_to_1(foreground: str, background: str) -> None:
    assert contrast(foreground, background) >= 4.5, (foreground, background)


def test_the_medal_ranks_stand_out_from_ordinary_rows() -> None:
    for fill, _ in web.MEDALS.values():
        assert contrast(fill, web.BACKGROUND) >= 3


def board(**changes: object) -> BoardView:
    fields: dict[str, object] = {
        "board_id": "club-final", "kind": "named", "title": "Club final", "description": "",
        "track": "reInvent2019_track", "track_name": "Smile Speedway", "direction": None,
        "race_type": RaceType.TIME_TRIAL, "method": TimingMethod.BEST_LAP_TIME, "min_laps": 1,
        "status": BoardStatus.OPEN, "opens_at": None, "closes_at": None, "cooldown_s": 0,
        "max_submissions": None, "participants": 0,
    }
    return BoardView.model_validate(fields | changes)


def page_of(view: BoardView, **options: object) -> str:
    return web.board_page(BoardPage(board=view, entries=[]), now=NOW, **options)  # type: ignore[arg-type]


def test_an_open_board_counts_down_to_its_close() -> None:
    html = page_of(board(closes_at=NOW + timedelta(hours=1, minutes=30)))
    assert '<span class="status open">Open</span>' in html
    assert "closes 2026-12-01 19:30 UTC (in <time" in html
    assert ">1 h 30 min</time>" in html and 'data-until="2026-12-01T19:30:00+00:00"' in html


def test_a_closed_board_says_so_and_stops_asking_for_pushes() -> None:
    html = page_of(board(status=BoardStatus.CLOSED, closes_at=NOW - timedelta(hours=1)),
                   endpoint="http://192.168.1.20:8000")
    assert '<span class="status closed">Closed</span>' in html
    assert "the standings are final" in html
    assert "To race" not in html


def test_an_upcoming_board_says_when_it_opens() -> None:
    html = page_of(board(status=BoardStatus.UPCOMING, opens_at=NOW + timedelta(days=2)))
    assert "opens 2026-12-03 18:00 UTC (in" in html and ">2 d</time>" in html


def test_the_rules_and_how_to_push_in_one_line_each() -> None:
    html = page_of(board(cooldown_s=600, max_submissions=5, description="Finals night"),
                   endpoint="http://192.168.1.20:8000")
    assert "Finals night" in html
    assert ("time trial · best lap, 1 lap to qualify · one push every 10 min · at most 5 "
            "submissions each") in html
    assert ("<code>drboard --endpoint http://192.168.1.20:8000 push ./my-model "
            "--board club-final</code>") in html


def test_the_big_screen_has_a_qr_code_of_the_page_and_scrolls() -> None:
    url = "http://192.168.1.20:8000/boards/club-final/view"
    html = page_of(board(), screen=True, url=url, qr_svg=web.qr_svg(url))
    assert 'class="screen"' in html
    assert "<svg" in html and f'aria-label="QR code of this page: {url}"' in html


def test_the_qr_code_encodes_the_url() -> None:
    segno = pytest.importorskip("segno")
    url = "https://abc.execute-api.eu-west-1.amazonaws.com/boards/club-final/view"
    assert web.qr_svg(url) == segno.make(url, error="m").svg_inline(
        scale=4, dark=web.BACKGROUND, light="#ffffff", omitsize=True)


def test_tables_have_column_headers_for_screen_readers() -> None:
    html = web.index_page([board(participants=3)])
    assert '<th scope="col">Board</th>' in html and "<caption" in html
    assert '<html lang="en">' in html
