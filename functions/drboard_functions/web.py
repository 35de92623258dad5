"""The leaderboard's web pages: server-rendered HTML, no dependency, no build step.

Everything a racer or an organiser supplied (names, models, board ids, titles) goes through
:func:`html.escape` or, in links, :func:`urllib.parse.quote`. A board's page keeps itself up to
date with one small inline script (allowed by its hash in the page's Content-Security-Policy):
it asks for the page again every few seconds with ``If-None-Match`` (an unchanged board answers
304 after one read) and at once when ``drboard serve`` streams a change, swaps the standings in
place, and marks new entries, improvements and a new leader for a few seconds. Without script,
the page reloads itself every 30 seconds.
"""

from __future__ import annotations

import base64
import hashlib
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
#live{color:#9aa7b4;font-size:.85rem;min-height:1.2em}
@keyframes glow{from{background:var(--glow)}to{background:transparent}}
tr.fresh td{--glow:#1f6f43;animation:glow 8s ease-out}
tr.improved td{--glow:#1d5a8c;animation:glow 8s ease-out}
tr.leader td{--glow:#8a6d00;animation:glow 10s ease-out}
""".strip()

#: Keeps a board's page live; see the module's docstring. Plain ES2017, no dependency.
LIVE_SCRIPT = """
(() => {
  const main = document.querySelector("main[data-board]");
  if (!main || !window.fetch) return;
  const live = () => document.getElementById("live");
  const say = (text) => { const el = live(); if (el) el.textContent = text; };
  const POLL_MS = 3000, STREAMED_POLL_MS = 30000;
  let etag = main.dataset.etag || null, busy = false, streamed = false;
  const rows = () => new Map([...main.querySelectorAll("tr[data-racer]")]
    .map((row) => [row.dataset.racer, row]));
  async function refresh() {
    if (busy) return;
    busy = true;
    try {
      const answer = await fetch(location.pathname + location.search,
        { headers: etag ? { "If-None-Match": etag } : {}, cache: "no-store" });
      if (answer.status === 304) { say("Live"); return; }
      const next = new DOMParser().parseFromString(await answer.text(), "text/html")
        .querySelector("main[data-board]");
      if (!next) throw new Error("not a board page");
      const before = rows(), leader = main.querySelector("tr[data-racer]");
      const hadEntries = before.size > 0 || main.dataset.missing === "1";
      main.innerHTML = next.innerHTML;
      main.dataset.missing = next.dataset.missing || "";
      etag = answer.headers.get("ETag") || next.dataset.etag || null;
      for (const [racer, row] of rows()) {
        const old = before.get(racer);
        if (!old && hadEntries) row.classList.add("fresh");
        else if (old && old.dataset.submission !== row.dataset.submission) row.classList.add("improved");
      }
      const top = main.querySelector("tr[data-racer]");
      if (top && leader && top.dataset.racer !== leader.dataset.racer) top.classList.add("leader");
      say(answer.status === 404 ? "Waiting for the board's first push" : "Live");
    } catch (error) {
      say("Reconnecting…");
    } finally {
      busy = false;
    }
  }
  function listen() {
    if (!window.EventSource) return;
    const stream = new EventSource(main.dataset.events);
    stream.addEventListener("board", () => { streamed = true; refresh(); });
    stream.onerror = () => { if (!streamed) stream.close(); };
  }
  (function tick() {
    refresh().finally(() => setTimeout(tick, streamed ? STREAMED_POLL_MS : POLL_MS));
  })();
  listen();
})();
""".strip()
LIVE_SCRIPT_HASH = "sha256-" + base64.b64encode(hashlib.sha256(LIVE_SCRIPT.encode()).digest()).decode()


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


def board_page(page: BoardPage, etag: str = "") -> str:
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
                     body + '<p><a href="/">All boards</a></p>',
                     live=_live_attributes(board.board_id, etag))


def waiting_page(board_id: str) -> str:
    """A board's page before the board exists: it shows the board as soon as the first run is
    pushed to it (a screen set up before the race starts)."""
    return _document(f"{board_id} · drboard", board_id,
                     "No run has been pushed to this board yet.",
                     "<p>This page shows the standings as soon as the first run arrives.</p>"
                     '<p><a href="/">All boards</a></p>',
                     live=_live_attributes(board_id, "") + ' data-missing="1"')


def _live_attributes(board_id: str, etag: str) -> str:
    events = "/boards/" + quote(board_id, safe="") + "/events"
    return (f' data-board="{escape(board_id)}" data-events="{escape(events)}"'
            f' data-etag="{escape(etag)}"')


def error_page(status: int, phrase: str, message: str) -> str:
    return _document(f"{status} {phrase} · drboard", phrase, message,
                     '<p><a href="/">All boards</a></p>', refresh=False)


def _entry_row(entry: EntryView) -> str:
    css = (f"q{entry.rank}" if entry.rank <= 3 else "") if entry.qualified else "dnq"
    data = (f' data-racer="{escape(entry.racer)}" data-submission="{escape(entry.submission_id)}"')
    row = f'<tr class="{css}"{data}>' if css else f"<tr{data}>"
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


def _document(title: str, heading: str, subtitle: str, body: str, refresh: bool = True,
              live: str = "") -> str:
    meta_refresh = f'<meta http-equiv="refresh" content="{REFRESH_S}">' if refresh else ""
    if live:  # the script keeps the page up to date; the refresh is for browsers without it
        meta_refresh = f"<noscript>{meta_refresh}</noscript>"
    script = f"<script>{LIVE_SCRIPT}</script>" if live else ""
    status = '<p id="live" role="status" aria-live="polite"></p>' if live else ""
    return (
        "<!doctype html>"
        '<html lang="en"><head><meta charset="utf-8">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"{meta_refresh}<title>{escape(title)}</title><style>{_STYLE}</style></head>"
        f"<body><main{live}><h1>{escape(heading)}</h1><p class=\"sub\">{escape(subtitle)}</p>"
        f"{status}{body}"
        "<footer>drboard, a collaborative leaderboard for AWS DeepRacer racers</footer>"
        f"</main>{script}</body></html>"
    )


def _flag_mark(flags: list[str]) -> str:
    """A mark beside a flagged run, its title saying which checks flagged it."""
    if not flags:
        return ""
    said = "; ".join(DESCRIPTIONS.get(flag, flag) for flag in flags)
    return f' <span class="flag" title="{escape(said)}" aria-label="flagged: {escape(said)}">⚑</span>'
