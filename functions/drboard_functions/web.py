"""The leaderboard's web pages: server-rendered HTML and SVG, no build step.

Everything a racer or an organiser supplied (names, models, board ids, titles) goes through
:func:`html.escape` or, in links, :func:`urllib.parse.quote`. A board's page keeps itself up to
date with one small inline script (allowed by its hash in the page's Content-Security-Policy):
it asks for the page again every few seconds with ``If-None-Match`` (an unchanged board answers
304 after one read) and at once when ``drboard serve`` streams a change, swaps the standings in
place, and marks new entries, improvements and a new leader for a few seconds; it also counts
down to the board's close and, on the big screen (``?screen=1``), scrolls through long boards.
Without script, the page reloads itself every 30 seconds.
"""

from __future__ import annotations

import base64
import hashlib
from collections.abc import Iterable
from datetime import datetime
from html import escape
from urllib.parse import quote, urlencode

from .display import DASH, duration, gap, method_label, percent, seconds, when
from .display import design_summary as _design_summary
from .flags import DESCRIPTIONS
from .models import BoardPage, BoardStatus, BoardView, Design, EntryView

REFRESH_S = 30

#: The page's colours. Every text colour is at least 4.5:1 against the backgrounds it sits on
#: (tests/unit/test_web_pages.py checks the pairs in TEXT_ON_BACKGROUND).
BACKGROUND = "#0f1720"
ROW_GLOW = {"fresh": "#173f2b", "improved": "#183a5a", "leader": "#453500"}
TEXT = "#e6edf3"
MUTED = "#9aa7b4"
LINK = "#7cc4ff"
MEDALS = {1: ("#ffd24d", "#1b1400"), 2: ("#d5dde5", "#11181f"), 3: ("#f0a868", "#1d0f02")}
STATUS_COLOURS = {BoardStatus.OPEN: ("#3fb950", "#04140a"),
                  BoardStatus.UPCOMING: ("#d29922", "#160f00"),
                  BoardStatus.CLOSED: ("#f85149", "#1a0303")}
TEXT_ON_BACKGROUND = (
    [(colour, BACKGROUND) for colour in (TEXT, MUTED, LINK)]
    + [(TEXT, glow) for glow in ROW_GLOW.values()]
    + [(MUTED, glow) for glow in ROW_GLOW.values()]
    + [(text, fill) for fill, text in MEDALS.values()]
    + [(text, fill) for fill, text in STATUS_COLOURS.values()]
)

_STYLE = (f"""
body{{font-family:system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;margin:0;
background:{BACKGROUND};color:{TEXT}}}
main{{max-width:72rem;margin:0 auto;padding:1.5rem}}
h1{{font-size:1.6rem;margin:.2rem 0}}
h2{{font-size:1.15rem;margin:1.6rem 0 .6rem}}
p.sub,p.rules,p.howto,#live{{color:{MUTED};margin:.2rem 0}}
p.howto code{{color:{TEXT}}}
a{{color:{LINK}}}
table{{border-collapse:collapse;width:100%;font-variant-numeric:tabular-nums}}
th,td{{padding:.45rem .6rem;text-align:left;border-bottom:1px solid #26313d;vertical-align:top}}
th{{color:{MUTED};font-weight:600;font-size:.85rem;text-transform:uppercase;letter-spacing:.03em}}
td.num,th.num{{text-align:right;white-space:nowrap}}
td.rank{{font-weight:700}}
td.rank span{{display:inline-block;min-width:1.6em;text-align:center;border-radius:.3em}}
td.design,span.model{{color:{MUTED};font-size:.9rem}}
tr.dnq td{{color:{MUTED}}}
.status{{display:inline-block;font-weight:700;padding:.05em .45em;border-radius:.3em}}
.board-head{{display:flex;gap:1.5rem;align-items:flex-start;justify-content:space-between}}
.qr svg{{display:block;width:9rem;height:9rem;border-radius:.3em}}
footer{{color:{MUTED};font-size:.8rem;margin-top:1.5rem}}
#live{{font-size:.85rem;min-height:1.2em}}
@keyframes glow{{from{{background:var(--glow)}}to{{background:transparent}}}}
@media (max-width:40rem){{main{{padding:.8rem}}.design,.laps{{display:none}}
th,td{{padding:.35rem .3rem}}.qr{{display:none}}code{{overflow-wrap:anywhere}}}}
main.screen{{max-width:none;padding:2vw 3vw;font-size:clamp(16px,1.05vw + 6px,44px)}}
main.screen h1{{font-size:2.2em}}
main.screen td.design,main.screen span.model{{font-size:.8em}}
main.screen .qr svg{{width:12vw;height:12vw;max-width:22rem;max-height:22rem}}
"""
    + "".join(f"tr.q{rank} td.rank span{{background:{fill};color:{text}}}"
              for rank, (fill, text) in MEDALS.items())
    + "".join(f".status.{status.value.lower()}{{background:{fill};color:{text}}}"
              for status, (fill, text) in STATUS_COLOURS.items())
    + "".join(f"tr.{name} td{{--glow:{colour};animation:glow 8s ease-out}}"
              for name, colour in ROW_GLOW.items())
).strip()

#: Keeps a board's page live; see the module's docstring. Plain ES2017, no dependency.
LIVE_SCRIPT = """
(() => {
  const main = document.querySelector("main[data-board]");
  if (!main || !window.fetch) return;
  const say = (text) => { const el = document.getElementById("live"); if (el) el.textContent = text; };
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
      countdown();
    } catch (error) {
      say("Reconnecting…");
    } finally {
      busy = false;
    }
  }
  function countdown() {
    for (const el of main.querySelectorAll("[data-until]")) {
      let left = Math.max(0, Math.round((Date.parse(el.dataset.until) - Date.now()) / 1000));
      const parts = [];
      for (const [size, unit] of [[86400, "d"], [3600, "h"], [60, "min"], [1, "s"]]) {
        if (left >= size || (unit === "s" && !parts.length)) {
          parts.push(Math.floor(left / size) + " " + unit);
          left %= size;
        }
      }
      el.textContent = parts.slice(0, 2).join(" ");
      if (el.dataset.until && Date.parse(el.dataset.until) <= Date.now()) refresh();
    }
  }
  function listen() {
    if (!window.EventSource) return;
    const stream = new EventSource(main.dataset.events);
    stream.addEventListener("board", () => { streamed = true; refresh(); });
    stream.onerror = () => { if (!streamed) stream.close(); };
  }
  function scroll() {
    // The big screen: down through a long board, a pause at each end, then back to the top.
    let pause = 200;
    setInterval(() => {
      const end = document.documentElement.scrollHeight - window.innerHeight;
      if (end <= 2) return;
      if (pause > 0) { pause -= 1; return; }
      if (window.scrollY >= end - 1) { window.scrollTo(0, 0); pause = 200; return; }
      window.scrollBy(0, 1);
      if (window.scrollY >= end - 1) pause = 200;
    }, 20);
  }
  (function tick() {
    refresh().finally(() => setTimeout(tick, streamed ? STREAMED_POLL_MS : POLL_MS));
  })();
  setInterval(countdown, 1000);
  listen();
  if (main.classList.contains("screen")) scroll();
})();
""".strip()
LIVE_SCRIPT_HASH = "sha256-" + base64.b64encode(hashlib.sha256(LIVE_SCRIPT.encode()).digest()).decode()


def board_path(board_id: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/view"


def racer_path(board_id: str, racer: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/racers/" + quote(racer, safe="") + "/view"


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
        f"<td>{_status_badge(b.status)}</td>"
        f'<td class="num">{b.participants}</td>'
        "</tr>"
        for b in boards
    ]
    if rows:
        body = ('<table><caption class="sub">Boards of this leaderboard</caption><thead><tr>'
                '<th scope="col">Board</th><th scope="col">Track</th><th scope="col">Race</th>'
                '<th scope="col">Timing</th><th scope="col">Status</th>'
                '<th scope="col" class="num">Racers</th></tr></thead><tbody>'
                + "".join(rows) + "</tbody></table>")
    else:
        body = "<p>No boards yet: push a run with <code>drboard push ./my-model</code>.</p>"
    return _document("drboard", "drboard", "Boards of this leaderboard.", body)


def board_page(page: BoardPage, etag: str = "", *, screen: bool = False, now: datetime,
               url: str = "", endpoint: str = "", qr_svg: str = "") -> str:
    """``/boards/{board}/view``: the board's status, window and rules, how to push, and the
    standings with gaps to the leader and each model's design. ``screen`` is the big-screen
    mode: sized for a room, a QR code of the page (``qr_svg``), auto-scrolling."""
    board = page.board
    rows = [_entry_row(board.board_id, entry) for entry in page.entries]
    if rows:
        body = ('<table><thead><tr><th scope="col" class="num">#</th><th scope="col">Racer</th>'
                '<th scope="col" class="num">Time</th><th scope="col" class="num">Gap</th>'
                '<th scope="col" class="num laps">Best lap</th>'
                '<th scope="col" class="num laps">Laps</th>'
                '<th scope="col" class="design">Design</th></tr></thead><tbody>'
                + "".join(rows) + "</tbody></table>")
    else:
        body = "<p>No entries on this page.</p>"
    if page.next_cursor:
        query = urlencode({"limit": len(page.entries), "cursor": page.next_cursor})
        body += f'<p><a href="{escape(board_path(board.board_id) + "?" + query)}">Next page</a></p>'
    racers = "racer" if board.participants == 1 else "racers"
    subtitle = f"{board.track_name} · {board.participants} {racers}"
    head = (f'<p class="sub">{_status_badge(board.status)} {_window(board, now)}</p>'
            + (f'<p class="sub">{escape(board.description)}</p>' if board.description else "")
            + f'<p class="rules">{escape(rules_line(board))}</p>'
            + _how_to_push(board, endpoint))
    if qr_svg:
        head = (f'<div class="board-head"><div>{head}</div><figure class="qr" role="img" '
                f'aria-label="QR code of this page: {escape(url)}">{qr_svg}</figure></div>')
    links = '<p><a href="/">All boards</a>'
    if page.entries:
        links += f' · <a href="{escape(_insights_path(board.board_id))}">What the fast models share</a>'
    links += "</p>"
    return _document(f"{board.title} · drboard", board.title, subtitle, head + body + links,
                     live=_live_attributes(board.board_id, etag, screen))


def waiting_page(board_id: str, screen: bool = False) -> str:
    """A board's page before the board exists: it shows the board as soon as the first run is
    pushed to it (a screen set up before the race starts)."""
    return _document(f"{board_id} · drboard", board_id,
                     "No run has been pushed to this board yet.",
                     "<p>This page shows the standings as soon as the first run arrives.</p>"
                     '<p><a href="/">All boards</a></p>',
                     live=_live_attributes(board_id, "", screen) + ' data-missing="1"')


def error_page(status: int, phrase: str, message: str) -> str:
    return _document(f"{status} {phrase} · drboard", phrase, message,
                     '<p><a href="/">All boards</a></p>', refresh=False)


def rules_line(board: BoardView) -> str:
    """The race rules in one line: timing, limits and what flagged runs do."""
    parts = [method_label(board)]
    if board.cooldown_s:
        parts.append(f"one push every {duration(board.cooldown_s)}")
    if board.max_submissions is not None:
        parts.append(f"at most {board.max_submissions} submissions each")
    if board.flagged_runs == "unranked":
        parts.append("flagged runs do not rank")
    race = board.race_type.value.replace("_", " ").lower()
    return f"{race} · " + " · ".join(parts)


def _window(board: BoardView, now: datetime) -> str:
    if board.status == BoardStatus.UPCOMING and board.opens_at:
        return f"opens {escape(when(board.opens_at))} (in {_until(board.opens_at, now)})"
    if board.status == BoardStatus.OPEN and board.closes_at:
        return f"closes {escape(when(board.closes_at))} (in {_until(board.closes_at, now)})"
    if board.status == BoardStatus.CLOSED and board.closes_at:
        return f"closed {escape(when(board.closes_at))}: the standings are final"
    return "no closing time" if board.status == BoardStatus.OPEN else ""


def _until(moment: datetime, now: datetime) -> str:
    left = max(0, int((moment - now).total_seconds()))
    return (f'<time data-until="{escape(moment.isoformat())}" datetime="{escape(moment.isoformat())}">'
            f"{escape(duration(left))}</time>")


def _how_to_push(board: BoardView, endpoint: str) -> str:
    if board.status == BoardStatus.CLOSED:
        return ""
    command = "drboard"
    if endpoint:
        command += f" --endpoint {endpoint}"
    command += " push ./my-model"
    if board.kind == "named":
        command += f" --board {board.board_id}"
    return f'<p class="howto">To race: <code>{escape(command)}</code></p>'


def qr_svg(url: str) -> str:
    """The QR code of ``url`` as inline SVG (dark on white, as phones read best)."""
    import segno  # only the big screen needs it

    return str(segno.make(url, error="m").svg_inline(scale=4, dark=BACKGROUND, light="#ffffff",
                                                      omitsize=True))


def _status_badge(status: BoardStatus) -> str:
    return f'<span class="status {status.value.lower()}">{status.value.capitalize()}</span>'


def _insights_path(board_id: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/insights/view"


def _live_attributes(board_id: str, etag: str, screen: bool) -> str:
    events = "/boards/" + quote(board_id, safe="") + "/events"
    return (f' data-board="{escape(board_id)}" data-events="{escape(events)}"'
            f' data-etag="{escape(etag)}"' + (' class="screen"' if screen else ""))


def _entry_row(board_id: str, entry: EntryView) -> str:
    css = (f"q{entry.rank}" if entry.rank <= 3 else "") if entry.qualified else "dnq"
    data = f' data-racer="{escape(entry.racer)}" data-submission="{escape(entry.submission_id)}"'
    row = f'<tr class="{css}"{data}>' if css else f"<tr{data}>"
    time = seconds(entry.time_ms) if entry.qualified else f"{percent(entry.best_completion_pct)} done"
    return (
        f"{row}"
        f'<td class="num rank"><span>{entry.rank}</span></td>'
        f'<td><a href="{escape(racer_path(board_id, entry.racer))}">{escape(entry.racer)}</a>'
        f'<br><span class="model">{escape(entry.model_name)}</span></td>'
        f'<td class="num">{escape(time)}{_flag_mark(entry.flags)}</td>'
        f'<td class="num">{escape(gap(entry.gap_ms) if entry.qualified else DASH)}</td>'
        f'<td class="num laps">{escape(seconds(entry.best_lap_ms))}</td>'
        f'<td class="num laps">{entry.laps_completed}</td>'
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
