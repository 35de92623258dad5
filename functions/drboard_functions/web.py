"""The leaderboard's web pages: server-rendered HTML, no script, no dependency.

Everything a racer or an organiser supplied (names, models, board ids, titles) goes through
:func:`html.escape` or, in links, :func:`urllib.parse.quote`. The pages refresh themselves every
30 seconds so a screen at an event keeps up with the board.
"""

from __future__ import annotations

from collections.abc import Iterable
from html import escape
from urllib.parse import quote, urlencode

from .display import DASH, gap, method_label, percent, seconds
from .display import design_summary as _design_summary
from .flags import DESCRIPTIONS
from .models import BoardPage, BoardView, Design, EntryView

REFRESH_S = 30
_STYLE = """
body{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;
background:#0f1720;color:#e6edf3}
main{max-width:72rem;margin:0 auto;padding:1.5rem}
h1{font-size:1.6rem;margin:.2rem 0}
p.sub{color:#9aa7b4;margin:.2rem 0 1.2rem}
a{color:#7cc4ff}
table{border-collapse:collapse;width:100%;font-variant-numeric:tabular-nums}
th,td{padding:.45rem .6rem;text-align:left;border-bottom:1px solid #26313d;vertical-align:top}
th{color:#9aa7b4;font-weight:600;font-size:.85rem;text-transform:uppercase;letter-spacing:.03em}
td.num,th.num{text-align:right}
tr.q1 td.rank{color:#ffd24d}tr.q2 td.rank{color:#c9d3dc}tr.q3 td.rank{color:#e0a070}
td.rank{font-weight:700}
td.design,span.model{color:#9aa7b4;font-size:.9rem}
tr.dnq td{color:#9aa7b4}
footer{color:#6b7886;font-size:.8rem;margin-top:1.5rem}
""".strip()


def board_path(board_id: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/view"


def design_summary(design: Design) -> str:
    return _design_summary(design, sensors=True)


# ---- pages --------------------------------------------------------------------------------------


def index_page(boards: Iterable[BoardView]) -> str:
    """``/``: every board, with its track, timing method and number of racers."""
    rows = [
        "<tr>"
        f'<td><a href="{escape(board_path(b.board_id))}">{escape(b.title)}</a></td>'
        f"<td>{escape(b.track_name)}</td>"
        f"<td>{escape(b.race_type.value.replace('_', ' ').lower())}</td>"
        f"<td>{escape(method_label(b))}</td>"
        f'<td class="num">{b.participants}</td>'
        "</tr>"
        for b in boards
    ]
    if rows:
        body = ("<table><thead><tr><th>Board</th><th>Track</th><th>Race</th><th>Timing</th>"
                '<th class="num">Racers</th></tr></thead><tbody>' + "".join(rows)
                + "</tbody></table>")
    else:
        body = "<p>No boards yet: push a run with <code>drboard push ./my-model</code>.</p>"
    return _document("drboard", "drboard", "Boards of this leaderboard.", body)


def board_page(page: BoardPage) -> str:
    """``/boards/{board}/view``: the standings, gaps to the leader and each model's design."""
    board = page.board
    rows = [_entry_row(entry) for entry in page.entries]
    if rows:
        body = ('<table><thead><tr><th class="num">#</th><th>Racer</th><th class="num">Time</th>'
                '<th class="num">Gap</th><th class="num">Best lap</th><th class="num">Laps</th>'
                "<th>Design</th></tr></thead><tbody>" + "".join(rows) + "</tbody></table>")
    else:
        body = "<p>No entries on this page.</p>"
    if page.next_cursor:
        query = urlencode({"limit": len(page.entries), "cursor": page.next_cursor})
        body += f'<p><a href="{escape(board_path(board.board_id) + "?" + query)}">Next page</a></p>'
    racers = "racer" if board.participants == 1 else "racers"
    subtitle = f"{board.track_name} · {method_label(board)} · {board.participants} {racers}"
    return _document(f"{board.title} · drboard", board.title, subtitle,
                     body + '<p><a href="/">All boards</a></p>')


def error_page(status: int, phrase: str, message: str) -> str:
    return _document(f"{status} {phrase} · drboard", phrase, message,
                     '<p><a href="/">All boards</a></p>', refresh=False)


def _entry_row(entry: EntryView) -> str:
    css = (f"q{entry.rank}" if entry.rank <= 3 else "") if entry.qualified else "dnq"
    row = f'<tr class="{css}">' if css else "<tr>"
    time = seconds(entry.time_ms) if entry.qualified else f"{percent(entry.best_completion_pct)} done"
    return (
        f"{row}"
        f'<td class="num rank">{entry.rank}</td>'
        f'<td>{escape(entry.racer)}<br><span class="model">{escape(entry.model_name)}</span></td>'
        f'<td class="num">{escape(time)}{_flag_mark(entry.flags)}</td>'
        f'<td class="num">{escape(gap(entry.gap_ms) if entry.qualified else DASH)}</td>'
        f'<td class="num">{escape(seconds(entry.best_lap_ms))}</td>'
        f'<td class="num">{entry.laps_completed}</td>'
        f'<td class="design">{escape(design_summary(entry.design))}</td>'
        "</tr>"
    )


def _document(title: str, heading: str, subtitle: str, body: str, refresh: bool = True) -> str:
    meta_refresh = f'<meta http-equiv="refresh" content="{REFRESH_S}">' if refresh else ""
    return (
        "<!doctype html>"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"{meta_refresh}<title>{escape(title)}</title><style>{_STYLE}</style></head>"
        f"<body><main><h1>{escape(heading)}</h1><p class=\"sub\">{escape(subtitle)}</p>{body}"
        "<footer>drboard, a collaborative leaderboard for AWS DeepRacer racers</footer>"
        "</main></body></html>"
    )


def _flag_mark(flags: list[str]) -> str:
    """A mark beside a flagged run, its title saying which checks flagged it."""
    if not flags:
        return ""
    said = "; ".join(DESCRIPTIONS.get(flag, flag) for flag in flags)
    return f' <span class="flag" title="{escape(said)}" aria-label="flagged: {escape(said)}">⚑</span>'
