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
from collections.abc import Iterable, Sequence
from datetime import datetime
from html import escape
from urllib.parse import quote, urlencode

from drboard_assembler.record import Record

from . import charts
from .display import DASH, PRIVATE_DESIGN, duration, gap, method_label, percent, seconds, when
from .display import design_summary as _design_summary
from .flags import DESCRIPTIONS
from .insights import LABELS, design_facts, fact_text
from .models.domain import BoardStatus, Design
from .models.seasons import SeasonLink
from .models.views import BoardPage, BoardView, Comparison, EntryView, Insights, RacerView

REFRESH_S = 30

#: The page's colours. Every text colour is at least 4.5:1 against the backgrounds it sits on
#: (tests/unit/test_web_pages.py checks every pair).
BACKGROUND = "#0f1720"
ROW_GLOW = {"fresh": "#173f2b", "improved": "#183a5a", "leader": "#453500"}
GLOW_S = 8  # how long a marked row glows (the style's animation; the script keeps marks as long)
TEXT = "#e6edf3"
MUTED = "#9aa7b4"
LINK = "#7cc4ff"
MEDALS = {1: ("#ffd24d", "#1b1400"), 2: ("#d5dde5", "#11181f"), 3: ("#f0a868", "#1d0f02")}
STATUS_COLOURS = {BoardStatus.OPEN: ("#3fb950", "#04140a"),
                  BoardStatus.UPCOMING: ("#d29922", "#160f00"),
                  BoardStatus.CLOSED: ("#f85149", "#1a0303")}

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
th{{color:{MUTED};font-weight:600}}
thead th{{font-size:.85rem;text-transform:uppercase;letter-spacing:.03em}}
.as-written{{text-transform:none}}
td.num,th.num{{text-align:right;white-space:nowrap}}
td.rank{{font-weight:700}}
td.rank span{{display:inline-block;min-width:1.6em;text-align:center;border-radius:.3em}}
td.design,span.model{{color:{MUTED};font-size:.9rem}}
tr.dnq td{{color:{MUTED}}}
.status{{display:inline-block;font-weight:700;padding:.05em .45em;border-radius:.3em}}
.board-head{{display:flex;gap:1.5rem;align-items:flex-start;justify-content:space-between}}
.qr svg{{display:block;width:9rem;height:9rem;border-radius:.3em}}
figure.chart{{margin:1rem 0;max-width:44rem}}figure.chart svg{{width:100%;height:auto}}
figcaption{{color:{MUTED};font-size:.85rem}}
tr.differs th,tr.differs td{{color:{TEXT};font-weight:700}}
tr.differs th::after{{content:" ≠"}}
section{{margin-top:1.2rem}}
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
    + "".join(f"tr.{name} td{{--glow:{colour};animation:glow {GLOW_S}s ease-out}}"
              for name, colour in ROW_GLOW.items())
).strip()

#: Keeps a board's page live; see the module's docstring. Plain ES2017, no dependency.
LIVE_SCRIPT = """
(() => {
  const main = document.querySelector("main[data-board]");
  if (!main || !window.fetch) return;
  const say = (text) => { const el = document.getElementById("live"); if (el) el.textContent = text; };
  const POLL_MS = 3000, STREAMED_POLL_MS = 30000, GLOW_MS = @GLOW_MS@;
  const marks = new Map();  // "fresh|improved|leader <racer>" -> when marked
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
      const now = Date.now(), after = rows();
      for (const [racer, row] of after) {
        const old = before.get(racer);
        if (!old && hadEntries) marks.set("fresh " + racer, now);
        else if (old && old.dataset.submission !== row.dataset.submission) {
          marks.set("improved " + racer, now);
        }
      }
      const top = main.querySelector("tr[data-racer]");
      if (top && leader && top.dataset.racer !== leader.dataset.racer) {
        marks.set("leader " + top.dataset.racer, now);
      }
      // A mark outlives the refreshes that follow it: its glow goes on where it was.
      for (const [mark, since] of marks) {
        if (now - since >= GLOW_MS) { marks.delete(mark); continue; }
        const cut = mark.indexOf(" "), row = after.get(mark.slice(cut + 1));
        if (!row) continue;
        row.classList.add(mark.slice(0, cut));
        for (const cell of row.cells) cell.style.animationDelay = (since - now) + "ms";
      }
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
""".strip().replace("@GLOW_MS@", str(GLOW_S * 1000))
LIVE_SCRIPT_HASH = "sha256-" + base64.b64encode(hashlib.sha256(LIVE_SCRIPT.encode()).digest()).decode()


def board_path(board_id: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/view"


def racer_path(board_id: str, racer: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/racers/" + quote(racer, safe="") + "/view"


def season_path(season_id: str) -> str:
    return "/seasons/" + quote(season_id, safe="") + "/view"


def design_summary(design: Design | None) -> str:
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
               url: str = "", endpoint: str = "", qr_svg: str = "",
               seasons: Sequence[SeasonLink] = ()) -> str:
    """``/boards/{board}/view``: the board's status, window and rules, the seasons it counts
    for, how to push, and the standings with gaps to the leader and each model's design.
    ``screen`` is the big-screen mode: sized for a room, a QR code of the page (``qr_svg``),
    auto-scrolling."""
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
            + _season_line(seasons) + _how_to_push(board, endpoint))
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


def racer_page(view: RacerView) -> str:
    """``/boards/{board}/racers/{racer}/view``: the counted run's laps, the action space, the
    hyperparameters, the training, the racer's submissions over time and any flags."""
    entry, record, board = view.entry, view.record, view.board
    standing = (f"#{entry.rank} on {board.title} · {seconds(entry.time_ms)}" if entry.qualified
                else f"#{entry.rank} on {board.title} · {percent(entry.best_completion_pct)} done")
    body = _flags_section(entry.flags)
    links = f'<p><a href="{escape(board_path(board.board_id))}">{escape(board.title)}</a></p>'
    if record is None:
        body += f"<p>How this model was built is {PRIVATE_DESIGN}.</p>" + _history_section(view)
        return _document(f"{view.racer} · {board.title} · drboard", view.racer,
                         f"{standing} · {entry.model_name}", body + links)
    run = record.best_run
    body += "<section><h2>Laps of the best evaluation run</h2>" + charts.bars(
        f"Lap times of {view.racer}'s best run",
        f"{len(run.laps)} laps of {run.source}; dim bars did not finish "
        f"(their completion is shown).",
        [charts.Bar(label=str(lap.trial),
                    value=lap.time_ms / 1000,
                    text=seconds(lap.time_ms) if lap.complete else percent(lap.completion_pct),
                    strong=lap.complete) for lap in run.laps], "seconds") + "</section>"
    body += "<section><h2>Action space</h2>" + _action_space_chart(record) + "</section>"
    body += "<section><h2>Design</h2>" + _facts_table([("model", record.model_name)] + [
        (label, value) for label, value in _design_rows(record)]) + "</section>"
    if record.training:
        training = record.training
        body += ("<section><h2>Training</h2>"
                 + _facts_table([("episodes", str(training.episodes)),
                                 ("training time", duration(int(training.training_time_s))),
                                 ("best reward", _number(training.best_reward)),
                                 ("mean reward", _number(training.mean_reward)),
                                 ("best completion", percent(training.best_completion_pct)),
                                 ("completed laps", str(training.completed_laps))])
                 + charts.line("Reward during training",
                               "Mean reward of each stretch of training episodes.",
                               [(p.episode, p.reward) for p in training.curve], "episode",
                               "reward")
                 + "</section>")
    body += _history_section(view)
    links = (f'<p><a href="{escape(board_path(board.board_id))}">{escape(board.title)}</a> · '
             f'<a href="{escape(_insights_path(board.board_id))}">What the fast models share</a></p>')
    return _document(f"{view.racer} · {board.title} · drboard", view.racer,
                     f"{standing} · {record.model_name}", body + links)


def _history_section(view: RacerView) -> str:
    timed = [charts.Point(x=n, y=item.time_ms / 1000,
                          label=f"{when(item.submitted_at)}: {seconds(item.time_ms)}",
                          strong=item.is_best)
             for n, item in enumerate(view.history, start=1) if item.time_ms is not None]
    rows = "".join(
        f"<tr><td>{escape(when(item.submitted_at))}</td><td>{escape(item.model_name)}</td>"
        f'<td class="num">{escape(_result(item.qualified, item.time_ms, item.best_completion_pct))}'
        f"{_flag_mark(item.flags)}</td><td>{'★ counts' if item.is_best else ''}</td></tr>"
        for item in view.history)
    return ("<section><h2>Submissions</h2><table><thead><tr><th scope=\"col\">When</th>"
             "<th scope=\"col\">Model</th><th scope=\"col\" class=\"num\">Time</th>"
             "<th scope=\"col\">Counted</th></tr></thead><tbody>" + rows + "</tbody></table>"
             + (charts.points("Times of the racer's submissions",
                              "Each submission's time, oldest on the left; the one that counts "
                              "is highlighted.", timed, "submission", "seconds")
                if len(timed) > 1 else "")
            + "</section>")


def compare_page(comparison: Comparison) -> str:
    """``/boards/{board}/compare/view?racer=A&racer=B``: the designs side by side, the facts
    they differ on marked."""
    board = comparison.board
    names = [c.racer for c in comparison.racers]
    head = "".join(f'<th scope="col">{escape(c.racer)} (#{c.entry.rank}, '
                   f'<span class="as-written">{escape(seconds(c.entry.time_ms))}</span>)</th>'
                   for c in comparison.racers)
    rows = []
    for fact, label in LABELS.items():
        cells = "".join(f"<td>{escape(fact_text(fact, getattr(c.facts, fact)))}</td>"
                        for c in comparison.racers)
        css = ' class="differs"' if fact in comparison.differences else ""
        rows.append(f'<tr{css}><th scope="row">{escape(label)}</th>{cells}</tr>')
    count = len(comparison.differences)
    summary = f"{count} difference{'s' if count != 1 else ''}, marked ≠."
    body = (f'<p class="rules">{escape(summary)}</p><table><thead><tr><th scope="col">Fact</th>'
            f"{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"
            f'<p><a href="{escape(board_path(board.board_id))}">{escape(board.title)}</a></p>')
    return _document(f"{' vs '.join(names)} · {board.title} · drboard", " vs ".join(names),
                     board.title, body)


def insights_page(insights: Insights) -> str:
    """``/boards/{board}/insights/view``: what the top models share against the field, and
    top speed against lap time."""
    board = insights.board
    rows = "".join(
        f'<tr><th scope="row">{escape(f.label)}</th><td>{escape(f.top)}{_share(f.top_share)}</td>'
        f"<td>{escape(f.field)}{_share(f.field_share)}</td></tr>" for f in insights.facts)
    body = (f'<p class="rules">The top {insights.top} qualified models against the board\'s '
            f"first {insights.field} entries: the most common choice and how many made it, or "
            "the median.</p>"
            '<table><thead><tr><th scope="col">Fact</th>'
            f'<th scope="col">Top {insights.top}</th><th scope="col">Field</th></tr></thead>'
            f"<tbody>{rows}</tbody></table>")
    timed = [p for p in insights.points if p.time_ms is not None]
    if timed:
        body += charts.points("Top speed against time",
                              "Each qualified entry's top speed and time; the top models "
                              "are highlighted.",
                              [charts.Point(x=p.max_speed, y=p.time_ms / 1000,
                                            label=f"{p.racer}: {p.max_speed:g} m/s, "
                                                  f"{seconds(p.time_ms)}", strong=p.top)
                               for p in timed if p.time_ms is not None],
                              "top speed (m/s)", "time (s)")
    body += f'<p><a href="{escape(board_path(board.board_id))}">{escape(board.title)}</a></p>'
    return _document(f"What the fast models share · {board.title} · drboard",
                     "What the fast models share", board.title, body)


def _result(qualified: bool, time_ms: int | None, completion_pct: float) -> str:
    return seconds(time_ms) if qualified else f"{percent(completion_pct)} done"


def _share(share: float | None) -> str:
    return "" if share is None else f" ({share:.0%})"


def _number(value: float | None) -> str:
    return DASH if value is None else f"{value:g}"


def _flags_section(flags: list[str]) -> str:
    if not flags:
        return ""
    items = "".join(f"<li>{escape(DESCRIPTIONS.get(flag, flag))}</li>" for flag in flags)
    return f'<section><h2>⚑ Flags</h2><ul class="flags">{items}</ul></section>'


def _design_rows(record: Record) -> list[tuple[str, str]]:
    facts = design_facts(record)
    rows = [(label, fact_text(name, getattr(facts, name))) for name, label in LABELS.items()
            if not name.startswith("training") and getattr(facts, name) is not None]
    hyper = record.design.hyperparameters
    shown = {"discount_factor", "lr", "batch_size", "beta_entropy", "num_epochs",
             "num_episodes_between_training", "loss_type"}
    rest = hyper.model_dump(exclude=shown | {"other"}, exclude_none=True) | hyper.other
    rows.extend((name.replace("_", " "), str(value)) for name, value in sorted(rest.items()))
    return rows


def _facts_table(rows: list[tuple[str, str]]) -> str:
    body = "".join(f'<tr><th scope="row">{escape(label)}</th><td>{escape(value)}</td></tr>'
                   for label, value in rows)
    return f"<table><tbody>{body}</tbody></table>"


def _action_space_chart(record: Record) -> str:
    space = record.design.action_space
    limit = max(space.max_steering, 1.0)
    if space.actions:
        return charts.points(
            "Action space", f"{len(space.actions)} actions: speed against steering angle.",
            [charts.Point(x=a.steering_angle, y=a.speed,
                          label=f"{a.steering_angle:g}°, {a.speed:g} m/s") for a in space.actions],
            "steering angle (°)", "speed (m/s)", x_range=(-limit, limit),
            y_range=(0, space.max_speed))
    assert space.speed is not None and space.steering_angle is not None
    return charts.points(
        "Action space", f"Continuous: {space.speed.low:g}–{space.speed.high:g} m/s, "
        f"{space.steering_angle.low:g}° to {space.steering_angle.high:g}°.", [],
        "steering angle (°)", "speed (m/s)", x_range=(-limit, limit), y_range=(0, space.max_speed),
        area=(space.steering_angle.low, space.steering_angle.high, space.speed.low,
              space.speed.high))


def error_page(status: int, phrase: str, message: str) -> str:
    return _document(f"{status} {phrase} · drboard", phrase, message,
                     '<p><a href="/">All boards</a></p>')


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


def _season_line(seasons: Sequence[SeasonLink]) -> str:
    """Which seasons the board counts for, and whose final it is (its only entrants are that
    season's qualifiers)."""
    if not seasons:
        return ""
    said = [("the final of " if link.final else "a round of ")
            + f'<a href="{escape(season_path(link.season_id))}">{escape(link.title)}</a>'
            + (" (only its qualifiers race)" if link.final else "") for link in seasons]
    return f'<p class="rules">This board is {"; ".join(said)}.</p>'


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
    time = _result(entry.qualified, entry.time_ms, entry.best_completion_pct)
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


def _document(title: str, heading: str, subtitle: str, body: str, live: str = "") -> str:
    # A live page keeps itself up to date with its script; browsers without script reload it.
    # Other pages never reload by themselves (a timed reload is an accessibility barrier).
    meta_refresh = (f'<noscript><meta http-equiv="refresh" content="{REFRESH_S}"></noscript>'
                    if live else "")
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
