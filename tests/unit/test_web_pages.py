"""The web pages as a projector, a phone and a screen reader meet them: contrast, status, window,
rules, how to push, the big screen's QR code."""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta

import pytest
from drboard_assembler.record import RaceType
from drboard_functions import web
from drboard_functions.models.domain import BoardStatus, TimingMethod
from drboard_functions.models.views import BoardPage, BoardView, EntryView

NOW = datetime(2026, 12, 1, 18, 0, tzinfo=UTC)


def contrast(foreground: str, background: str) -> float:
    """WCAG 2 contrast ratio of two #rrggbb colours."""
    def luminance(colour: str) -> float:
        channels = [int(colour[i:i + 2], 16) / 255 for i in (1, 3, 5)]
        linear = [c / 12.92 if c <= 0.03928 else ((c + 0.055) / 1.055) ** 2.4 for c in channels]
        return 0.2126 * linear[0] + 0.7152 * linear[1] + 0.0722 * linear[2]
    light, dark = sorted((luminance(foreground), luminance(background)), reverse=True)
    return (light + 0.05) / (dark + 0.05)


def palette() -> dict[str, str]:
    """The pages' colours, as the style sheet's custom properties define them."""
    style = web.assets().style
    root = style[style.index(":root"):style.index("}", style.index(":root"))]
    return dict(re.findall(r"--([a-z-]+):\s*(#[0-9a-f]{6})", root))


COLOURS = palette()
#: Every text colour of the pages, with each background it sits on: the page's, each marked
#: row's fill, each medal, status badge and banner.
FILLS = ("fresh", "improved", "leader", "gold", "silver", "bronze", "open", "upcoming", "closed",
         "lost", "back")
TEXT_ON_BACKGROUND = (
    [(name, "background") for name in ("text", "muted", "link")]
    + [(f"{fill}-text", fill) for fill in FILLS]
)


@pytest.mark.parametrize(("foreground", "background"), TEXT_ON_BACKGROUND)
def test_every_text_colour_reads_at_4_5_to_1(foreground: str, background: str) -> None:
    assert contrast(COLOURS[foreground], COLOURS[background]) >= 4.5, (foreground, background)


@pytest.mark.parametrize("fill", ["fresh", "improved", "leader", "gold", "silver", "bronze"])
def test_marked_rows_and_medals_stand_out_from_the_page_at_3_to_1(fill: str) -> None:
    assert contrast(COLOURS[fill], COLOURS["background"]) >= 3


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


def test_with_a_join_code_the_page_shows_the_join_command_and_a_push_without_endpoint() -> None:
    html = page_of(board(), endpoint="http://192.168.1.20:8000", join_code="K7QM-3XWD")
    assert ("drboard join <strong>K7QM-3XWD</strong> --endpoint http://192.168.1.20:8000"
            in html)
    assert "<code>drboard push ./my-model --board club-final</code>" in html
    closed = page_of(board(status=BoardStatus.CLOSED), endpoint="http://x:1", join_code="K7QM-3XWD")
    assert "K7QM-3XWD" not in closed


def test_the_big_screen_has_the_join_code_and_a_qr_code_of_the_address_and_code() -> None:
    invite = web.Invite(endpoint="http://192.168.1.20:8000", code="K7QM-3XWD")
    html = page_of(board(), screen=True, url=invite.join_url, qr_svg=web.qr_svg(invite.join_url),
                   endpoint=invite.endpoint, join_code=invite.code)
    assert 'class="screen"' in html
    assert invite.join_url == "http://192.168.1.20:8000/join?code=K7QM-3XWD"
    assert "<svg" in html and f'aria-label="QR code: {invite.join_url}"' in html
    assert "Scan to join" in html and "<strong>K7QM-3XWD</strong>" in html


def test_the_qr_code_encodes_the_url() -> None:
    segno = pytest.importorskip("segno")
    url = "https://abc.execute-api.eu-west-1.amazonaws.com/boards/club-final/view"
    assert web.qr_svg(url) == segno.make(url, error="m").svg_inline(
        scale=4, dark=COLOURS["background"], light="#ffffff", omitsize=True)


def test_the_pages_inline_only_the_static_style_and_script_allowed_by_hash() -> None:
    html = page_of(board())
    assert f"<style>{web.assets().style}</style>" in html
    assert f"<script>{web.assets().script}</script>" in html
    policy = web.content_security_policy(live=True)
    assert f"style-src '{web.assets().style_hash}'" in policy
    assert f"script-src '{web.assets().script_hash}'" in policy
    assert "unsafe-inline" not in policy and "script-src" not in web.content_security_policy(live=False)


def entry(racer: str, rank: int, time_ms: int, **changes: object) -> EntryView:
    fields: dict[str, object] = {
        "rank": rank, "racer": racer, "model_name": f"{racer.lower()}-model", "qualified": True,
        "time_ms": time_ms, "gap_ms": time_ms - 8655, "best_lap_ms": time_ms, "laps_completed": 3,
        "best_completion_pct": 100.0, "submitted_at": NOW, "submission_id": "s" * 64,
        "design": {"algorithm": "clipped_ppo", "action_space": "discrete", "actions": 10,
                   "max_speed": 4.0, "max_steering": 25.0, "sensors": ["FRONT_FACING_CAMERA"]},
    }
    return EntryView.model_validate(fields | changes)


def standings(view: BoardView, **options: object) -> str:
    entries = [entry("Blaze", 1, 8655), entry("<b>Indy</b>", 2, 9120)]
    return web.board_page(BoardPage(board=view, entries=entries), now=NOW, **options)  # type: ignore[arg-type]


def test_a_best_lap_board_does_not_repeat_its_time_as_a_best_lap_column() -> None:
    best_lap = standings(board(participants=2))
    assert 'class="num time">Best lap</th>' in best_lap
    assert best_lap.count(">Best lap</th>") == 1
    average = standings(board(method=TimingMethod.AVG_LAP_TIME, min_laps=3, participants=2))
    assert 'class="num time">Average</th>' in average and ">Best lap</th>" in average


def test_each_row_links_its_racer_and_a_comparison_with_the_leader_escaped() -> None:
    html = standings(board(participants=2))
    assert "&lt;b&gt;Indy&lt;/b&gt;" in html and "<b>Indy" not in html
    assert 'href="/boards/club-final/compare/view?racer=Blaze&amp;racer=%3Cb%3EIndy%3C%2Fb%3E"' in html
    assert 'data-rank="2"' in html
    assert "Compare the top two" in html
    assert 'class="compare"' not in standings(board(participants=2), screen=True)


def test_every_table_of_the_pages_stacks_on_a_phone() -> None:
    html = standings(board(participants=2))
    assert html.count("<table") == html.count('<table class="standings stack"')
    index = web.index_page([board(participants=3)])
    assert index.count("<table") == index.count('<table class="stack"') == 1


def test_the_board_page_links_every_lap_as_csv_when_its_laps_show() -> None:
    link = '<a href="/boards/club-final/laps.csv" download>Download every lap (CSV)</a>'
    assert link in standings(board(participants=2))
    assert link not in standings(board(participants=2), screen=True), "not on the big screen"
    assert link not in page_of(board()), "nothing to download on an empty board"
    private = board(participants=2, designs="after-close")
    assert link not in standings(private), "laps stay private with the designs until the close"
    assert link in standings(private.model_copy(update={"status": BoardStatus.CLOSED}))
