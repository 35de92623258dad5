"""The leaderboard's web pages: Jinja2 templates (``templates/``) and one style sheet and one
script (``static/``), server-rendered, no build step.

The templates autoescape everything a racer or an organiser supplied (names, models, board ids,
titles); links are built with :func:`urllib.parse.quote`. The style sheet and the script are
inlined into each page and allowed by their hashes in the page's Content-Security-Policy
(:func:`content_security_policy`), so a page loads nothing else and runs nothing else.

Jinja2 is imported, and its environment built, on the first page a process renders, and the
charts' module on the first page that draws one: the pull function's JSON routes never pay for
them at a cold start.

A board's page keeps itself up to date with the script (``static/live.js``): see its comment.
Without script, it reloads itself every 30 seconds.
"""

from __future__ import annotations

import base64
import hashlib
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime
from functools import cache
from importlib.resources import files
from typing import TYPE_CHECKING, Any
from urllib.parse import quote, urlencode

from drboard_assembler.record import Record

from . import conditions as condition_texts
from .display import DASH, PRIVATE_DESIGN, UNKNOWN, duration, gap, method_label, percent, seconds, when
from .display import design_summary as _design_summary
from .flags import DESCRIPTIONS
from .insights import LABELS, algorithm_differences, design_facts, fact_text
from .models.domain import BoardStatus, Design, TimingMethod
from .models.racer_views import Comparison, Insights, RacerView
from .models.seasons import SeasonLink
from .models.views import BoardPage, BoardView, EntryView
from .templating import environment

if TYPE_CHECKING:  # loads with the first page that needs it (see the module's docstring)
    from . import charts

REFRESH_S = 30


@dataclass(frozen=True)
class Invite:
    """How racers reach and join a `drboard serve` board: its network address (never
    ``0.0.0.0`` or ``localhost``) and the room's join code (None where racers sign in another
    way)."""

    endpoint: str
    code: str | None = None

    @property
    def join_url(self) -> str:
        """Where the big screen's QR code leads: a page saying the command, code included."""
        return f"{self.endpoint}/join?" + urlencode({"code": self.code or ""})


@dataclass(frozen=True)
class Share:
    """What a page's Open Graph and Twitter meta say, so that a link to it pasted in a chat
    unfurls as its result card: absolute URLs (a link preview knows no page to resolve against)."""

    title: str
    description: str
    url: str  # the page's own
    image: str  # the card's PNG
    alt: str
    card_path: str  # the card's PNG, on this origin (the page shows it)
    svg_path: str
    width: int = 1200
    height: int = 630


@dataclass(frozen=True)
class Assets:
    """The style sheet and the script every page inlines, and their CSP hashes."""

    style: str
    script: str

    @property
    def style_hash(self) -> str:
        return csp_hash(self.style)

    @property
    def script_hash(self) -> str:
        return csp_hash(self.script)


def csp_hash(text: str) -> str:
    return "sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode()


@cache
def assets() -> Assets:
    static = files("drboard_functions") / "static"
    return Assets(style=(static / "drboard.css").read_text("utf-8"),
                  script=(static / "live.js").read_text("utf-8"))


def content_security_policy(*, live: bool) -> str:
    """The pages load nothing: their own inlined style (and, for a live page, script, which
    talks only to its own origin) allowed by hash."""
    policy = (f"default-src 'none'; style-src '{assets().style_hash}'; img-src 'self'; "
              "base-uri 'none'; form-action 'none'; frame-ancestors 'none'")
    if live:
        policy += f"; script-src '{assets().script_hash}'; connect-src 'self'"
    return policy


def _render(template: str, *, title: str, heading: str, subtitle: str, live: dict[str, Any] | None = None,
            screen: bool = False, share: Share | None = None, **context: Any) -> str:
    return environment().get_template(template).render(
        title=title, heading=heading, subtitle=subtitle, live=live, screen=screen, share=share,
        refresh_s=REFRESH_S, assets=assets(), **context)


# ---- paths -----------------------------------------------------------------------------------


def board_path(board_id: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/view"


def season_path(season_id: str) -> str:
    return "/seasons/" + quote(season_id, safe="") + "/view"


def racer_path(board_id: str, racer: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/racers/" + quote(racer, safe="") + "/view"


def season_card_path(season_id: str, kind: str = "png") -> str:
    """A season's podium card (``png`` or ``svg``), served by the card routes."""
    return "/seasons/" + quote(season_id, safe="") + f"/card.{kind}"


def podium_path(season_id: str) -> str:
    """A season's podium page: its card and the certificates of its first three, to print."""
    return "/seasons/" + quote(season_id, safe="") + "/podium/view"


def racer_card_path(board_id: str, racer: str, kind: str = "png") -> str:
    """A racer's result card (``png`` or ``svg``), served by the card routes."""
    return "/boards/" + quote(board_id, safe="") + "/racers/" + quote(racer, safe="") + f"/card.{kind}"


def compare_path(board_id: str, racers: Sequence[str]) -> str:
    return ("/boards/" + quote(board_id, safe="") + "/compare/view?"
            + urlencode([("racer", racer) for racer in racers]))


def _insights_path(board_id: str) -> str:
    return "/boards/" + quote(board_id, safe="") + "/insights/view"


def laps_path(board_id: str) -> str:
    """Every lap of the board's submissions, as CSV (``drboard export --laps`` reads it too)."""
    return "/boards/" + quote(board_id, safe="") + "/laps.csv"


def design_summary(design: Design | None) -> str:
    return _design_summary(design, sensors=True)


# ---- pages -----------------------------------------------------------------------------------


def index_page(boards: Iterable[BoardView]) -> str:
    """``/``: every board, with its track, timing method and number of racers."""
    listed = [{"path": board_path(b.board_id), "title": b.title, "track_name": b.track_name,
               "race": _race(b), "timing": method_label(b), "status": b.status,
               "participants": b.participants} for b in boards]
    return _render("index.html", title="drboard", heading="drboard",
                   subtitle="Boards of this leaderboard.", boards=listed)


def board_page(page: BoardPage, etag: str = "", *, screen: bool = False, now: datetime,
               url: str = "", endpoint: str = "", qr_svg: str = "",
               join_code: str | None = None, seasons: Sequence[SeasonLink] = ()) -> str:
    """``/boards/{board}/view``: the board's status, window and rules, the seasons it counts
    for (and whose final it is), how to join and push, and the standings with gaps to the
    leader and each model's design. ``screen`` is the
    big-screen mode: sized for a room, one line a racer, the join code and a QR code
    (``qr_svg``, of ``url``), auto-scrolling."""
    board = page.board
    leader = page.entries[0].racer if page.entries and page.entries[0].rank == 1 else None
    entries = [_entry(board.board_id, entry, leader, conditions=not screen and board.conditions is None)
               for entry in page.entries]
    racers = "racer" if board.participants == 1 else "racers"
    next_path = None
    if page.next_cursor:
        next_path = board_path(board.board_id) + "?" + urlencode(
            {"limit": len(page.entries), "cursor": page.next_cursor})
    join = {"code": join_code, "endpoint": endpoint} if join_code and _open(board) else None
    qr = None
    if qr_svg:
        qr = {"svg": _markup(qr_svg), "text": url,
              "caption": "Scan to join" if join else "Scan for this board"}
    qualified = [e for e in page.entries if e.qualified]
    return _render(
        "board.html", title=f"{board.title} · drboard", heading=board.title,
        subtitle=f"{board.track_name} · {board.participants} {racers}",
        live=_live(board.board_id, etag), screen=screen, board=board,
        window=_markup(_window(board, now)), rules=rules_line(board), join=join, qr=qr,
        push_command=_push_command(board, endpoint, joined=join is not None), entries=entries,
        time_label=_time_label(board), best_lap_column=board.method != TimingMethod.BEST_LAP_TIME,
        next_path=next_path, insights_path=_insights_path(board.board_id),
        laps_path=laps_path(board.board_id) if _laps_shown(board) else None,
        compare_top_path=(compare_path(board.board_id, [q.racer for q in qualified[:2]])
                          if len(qualified) >= 2 and not screen else None),
        screen_path=board_path(board.board_id) + "?screen=1",
        seasons=[{"path": season_path(link.season_id), "title": link.title, "final": link.final}
                 for link in seasons])


def waiting_page(board_id: str, screen: bool = False, *, join_code: str | None = None,
                 endpoint: str = "") -> str:
    """A board's page before the board exists: it shows the board as soon as the first run is
    pushed to it (a screen set up before the race starts)."""
    return _render("waiting.html", title=f"{board_id} · drboard", heading=board_id,
                   subtitle="No run has been pushed to this board yet.",
                   live=_live(board_id, "", missing=True), screen=screen,
                   join={"code": join_code, "endpoint": endpoint} if join_code else None)


def join_page(invite: Invite, boards: Iterable[BoardView]) -> str:
    """``GET /join`` on `drboard serve` (where the big screen's QR code leads): the command
    that joins, and the boards."""
    return _render("join.html", title="Join · drboard", heading="Join this board",
                   subtitle=f"Join code {invite.code}", join=invite,
                   boards=[{"path": board_path(b.board_id), "title": b.title} for b in boards])


def racer_page(view: RacerView, *, leader: str | None = None, ahead: str | None = None,
               origin: str = "") -> str:
    """``/boards/{board}/racers/{racer}/view``: the racer's result card (named in the page's
    Open Graph meta, with ``origin`` for its absolute URLs), the counted run's laps, the action
    space, the hyperparameters, the training, the racer's submissions over time and any flags,
    and links to compare with the leader and the racer just ahead."""
    from . import charts

    entry, record, board = view.entry, view.record, view.board
    standing = (f"#{entry.rank} on {board.title} · {seconds(entry.time_ms)}" if entry.qualified
                else f"#{entry.rank} on {board.title} · {percent(entry.best_completion_pct)} done")
    result = (f"{seconds(entry.time_ms)}, " + ("the leader" if entry.rank == 1 else
                                              f"{gap(entry.gap_ms)} to the leader")
              if entry.qualified else f"{percent(entry.best_completion_pct)} done")
    card = racer_card_path(board.board_id, view.racer)
    share = Share(
        title=f"{view.racer}: #{entry.rank} of {board.participants} on {board.title}",
        description=f"{result} with {entry.model_name} · {board.track_name}, {method_label(board)}.",
        url=origin + racer_path(board.board_id, view.racer), image=origin + card,
        alt=f"Result card: {view.racer}, #{entry.rank} on {board.title}, {result}, model "
            f"{entry.model_name}",
        card_path=card, svg_path=racer_card_path(board.board_id, view.racer, "svg"))
    links: list[dict[str, str]] = []
    for other, text in ((leader, "Compare with the leader, {}"), (ahead, "Compare with {}, just ahead")):
        if other and other != view.racer and all(other not in link["text"] for link in links):
            links.append({"path": compare_path(board.board_id, [other, view.racer]),
                          "text": text.format(other)})
    context: dict[str, Any] = {
        "flags": [DESCRIPTIONS.get(flag, flag) for flag in entry.flags],
        "history": [{"when": when(item.submitted_at), "model_name": item.model_name,
                     "result": _result(item.qualified, item.time_ms, item.best_completion_pct),
                     "flags": _flag_text(item.flags), "is_best": item.is_best}
                    for item in view.history],
        "history_chart": _history_chart(view), "board": board,
        "board_path": board_path(board.board_id), "insights_path": _insights_path(board.board_id),
        "compare_links": links if record is not None else [],
        "private": PRIVATE_DESIGN if record is None else None,
    }
    title = f"{view.racer} · {board.title} · drboard"
    context["share"] = share
    if record is None:
        return _render("racer.html", title=title, heading=view.racer,
                       subtitle=f"{standing} · {entry.model_name}", **context)
    run = view.scored_run or record.best_run
    context["laps_chart"] = charts.bars(
        f"Lap times of {view.racer}'s best run",
        f"{len(run.laps)} laps of {run.source}; dim bars did not finish (their completion is shown).",
        [charts.Bar(label=str(lap.trial), value=lap.time_ms / 1000,
                    text=seconds(lap.time_ms) if lap.complete else percent(lap.completion_pct),
                    strong=lap.complete) for lap in run.laps], "seconds")
    context["action_chart"] = _action_space_chart(record)
    context["design"] = [("model", record.model_name), *_design_rows(record)]
    context["sources"] = _source_rows(record)
    context["conditions"] = condition_texts.rows(entry.conditions)
    context["penalties_note"] = condition_texts.PENALTIES_NOTE
    context["training"] = None
    context["training_chart"] = None
    if record.training:
        training = record.training
        context["training"] = [("episodes", str(training.episodes)),
                               ("training time", duration(int(training.training_time_s))),
                               ("best reward", _number(training.best_reward)),
                               ("mean reward", _number(training.mean_reward)),
                               ("best completion", percent(training.best_completion_pct)),
                               ("completed laps", str(training.completed_laps))]
        context["training_chart"] = charts.line(
            "Reward during training", "Mean reward of each stretch of training episodes.",
            [(p.episode, p.reward) for p in training.curve], "episode", "reward")
    return _render("racer.html", title=title, heading=view.racer,
                   subtitle=f"{standing} · {record.model_name}", **context)


def _history_chart(view: RacerView) -> charts.Figure | None:
    from . import charts

    timed = [charts.Point(x=n, y=item.time_ms / 1000,
                          label=f"{when(item.submitted_at)}: {seconds(item.time_ms)}",
                          strong=item.is_best)
             for n, item in enumerate(view.history, start=1) if item.time_ms is not None]
    if len(timed) < 2:
        return None
    return charts.points("Times of the racer's submissions",
                         "Each submission's time, oldest on the left; the one that counts is "
                         "highlighted.", timed, "submission", "seconds")


def compare_page(comparison: Comparison, records: Sequence[Record | None] = ()) -> str:
    """``/boards/{board}/compare/view?racer=A&racer=B``: why one is faster. The racers' best
    runs lap by lap (a chart and a table), then the design choices they made differently, then
    the differences that follow from their algorithms alone, then what they share.
    ``records`` are the racers' best records, in the comparison's order (None: not known)."""
    board = comparison.board
    names = [c.racer for c in comparison.racers]
    runs = [record.best_run if record is not None else None for record in records]
    runs += [None] * (len(names) - len(runs))
    by_algorithm = set(algorithm_differences([c.facts for c in comparison.racers],
                                             comparison.differences))
    rows = {"choices": [], "by_algorithm": [], "same": []}  # type: dict[str, list[dict[str, Any]]]
    for fact, label in LABELS.items():
        values = [fact_text(fact, getattr(c.facts, fact), fact in c.facts.unknown)
                  for c in comparison.racers]
        differs = fact in comparison.differences
        group = "by_algorithm" if fact in by_algorithm else "choices" if differs else "same"
        rows[group].append({"label": label, "cells": values, "differs": differs})
    count = len(comparison.differences)
    standings = " vs ".join(f"{c.racer} (#{c.entry.rank}, {_entry_result(c.entry)})"
                            for c in comparison.racers)
    summary = f"{standings} · {count} design difference{'s' if count != 1 else ''}"
    algorithms = sorted({fact_text("algorithm", c.facts.algorithm) for c in comparison.racers})
    return _render(
        "compare.html", title=f"{' vs '.join(names)} · {board.title} · drboard",
        heading=" vs ".join(names), subtitle=board.title, summary=summary, racers=names,
        laps_chart=_laps_chart(names, runs), laps=_lap_rows(runs),
        choices=rows["choices"], by_algorithm=rows["by_algorithm"], same=rows["same"],
        algorithm_note=(f"{' and '.join(algorithms)} train differently: SAC learns only over a "
                        "continuous action space and has no entropy or epochs settings, so these "
                        "differences come with the algorithm, not with a choice."),
        board=board, board_path=board_path(board.board_id),
        racer_links=[{"path": racer_path(board.board_id, name), "text": f"{name}'s page"}
                     for name in names])


def _laps_chart(names: Sequence[str], runs: Sequence[Any]) -> charts.Figure:
    from . import charts

    series = []
    for name, run in zip(names, runs, strict=True):
        laps = run.laps if run is not None else []
        series.append(charts.Series(name, [
            (lap.trial, lap.time_ms / 1000 if lap.complete else None,
             f"{name}, lap {lap.trial}: {seconds(lap.time_ms)}") for lap in laps]))
    return charts.lines("Lap times of each racer's best run",
                        "Each racer's best evaluation run, lap by lap (lower is faster); a gap is "
                        "a lap that did not finish.", series, "lap", "seconds")


def _lap_rows(runs: Sequence[Any]) -> list[dict[str, Any]]:
    count = max((len(run.laps) for run in runs if run is not None), default=0)
    rows = []
    for index in range(count):
        laps = [run.laps[index] if run is not None and index < len(run.laps) else None
                for run in runs]
        times = [lap.time_ms if lap is not None and lap.complete else None for lap in laps]
        best = min((t for t in times if t is not None), default=None)
        cells = [{"text": DASH if lap is None else seconds(lap.time_ms) if lap.complete
                  else f"{percent(lap.completion_pct)} done",
                  "fastest": best is not None and time == best and len(laps) > 1}
                 for lap, time in zip(laps, times, strict=True)]
        difference = DASH
        if len(times) == 2 and times[0] is not None and times[1] is not None:
            difference = f"{(times[1] - times[0]) / 1000:+.3f} s"
        rows.append({"number": index + 1, "cells": cells, "difference": difference})
    return rows


def insights_page(insights: Insights) -> str:
    """``/boards/{board}/insights/view``: what the top models share against the field, and
    top speed against lap time."""
    from . import charts

    board = insights.board
    facts = [{"label": f.label, "top": f.top + _share(f.top_share),
              "field": f.field + _share(f.field_share)} for f in insights.facts]
    timed = [p for p in insights.points if p.time_ms is not None]
    chart = None
    if timed:
        chart = charts.points("Top speed against time",
                              "Each qualified entry's top speed and time; the top models are "
                              "highlighted.",
                              [charts.Point(x=p.max_speed, y=p.time_ms / 1000,
                                            label=f"{p.racer}: {p.max_speed:g} m/s, {seconds(p.time_ms)}",
                                            strong=p.top)
                               for p in timed if p.time_ms is not None],
                              "top speed (m/s)", "time (s)")
    return _render("insights.html", title=f"What the fast models share · {board.title} · drboard",
                   heading="What the fast models share", subtitle=board.title, top=insights.top,
                   field=insights.field, facts=facts, speed_chart=chart, board=board,
                   board_path=board_path(board.board_id))


def error_page(status: int, phrase: str, message: str) -> str:
    return _render("error.html", title=f"{status} {phrase} · drboard", heading=phrase,
                   subtitle=message)


def rules_line(board: BoardView) -> str:
    """The race rules in one line: timing, limits and what flagged runs do."""
    parts = [method_label(board)]
    if board.cooldown_s:
        parts.append(f"one push every {duration(board.cooldown_s)}")
    if board.max_submissions is not None:
        parts.append(f"at most {board.max_submissions} submissions each")
    if board.flagged_runs == "unranked":
        parts.append("flagged runs do not rank")
    if board.conditions is not None:
        parts.append(f"evaluated with {condition_texts.summary(board.conditions)}")
    parts.append("times include penalties")
    return f"{_race(board)} · " + " · ".join(parts)


def qr_svg(url: str) -> str:
    """The QR code of ``url`` as inline SVG (dark on white, as phones read best)."""
    import segno  # only the big screen needs it

    return str(segno.make(url, error="m").svg_inline(scale=4, dark="#0f1720", light="#ffffff",
                                                      omitsize=True))


# ---- pieces ----------------------------------------------------------------------------------


def _markup(html: str) -> Any:
    """HTML this module built itself (escaping what it holds), to go into a template as it is."""
    from markupsafe import Markup

    return Markup(html)


def _race(board: BoardView) -> str:
    return board.race_type.value.replace("_", " ").lower()


def _open(board: BoardView) -> bool:
    return board.status != BoardStatus.CLOSED


def _laps_shown(board: BoardView) -> bool:
    """Whether the board's laps may be downloaded: they show with the designs (a board that
    keeps its designs private until it closes keeps its laps too)."""
    return board.participants > 0 and (board.designs == "public" or board.status == BoardStatus.CLOSED)


def _time_label(board: BoardView) -> str:
    return {TimingMethod.BEST_LAP_TIME: "Best lap", TimingMethod.AVG_LAP_TIME: "Average",
            TimingMethod.TOTAL_TIME: "Total"}.get(board.method, "Time")


def _live(board_id: str, etag: str, missing: bool = False) -> dict[str, Any]:
    return {"board_id": board_id, "events": "/boards/" + quote(board_id, safe="") + "/events",
            "etag": etag, "missing": missing}


def _entry(board_id: str, entry: EntryView, leader: str | None, *,
           conditions: bool = False) -> dict[str, Any]:
    """One row of the standings; with ``conditions`` (a board that takes runs of any
    conditions), what the entry's evaluation ran under."""
    css = (f"q{entry.rank}" if entry.rank <= 3 else "") if entry.qualified else "dnq"
    return {
        "css": css, "racer": entry.racer, "submission_id": entry.submission_id, "rank": entry.rank,
        "path": racer_path(board_id, entry.racer), "model_name": entry.model_name,
        "time": _entry_result(entry), "flags": _flag_text(entry.flags),
        "gap": gap(entry.gap_ms) if entry.qualified else DASH,
        "best_lap": seconds(entry.best_lap_ms), "laps": entry.laps_completed,
        "design": design_summary(entry.design),
        "conditions": condition_texts.short(entry.conditions) if conditions else "",
        "compare_path": (compare_path(board_id, [leader, entry.racer])
                         if leader and leader != entry.racer and entry.design is not None else None),
    }


def _entry_result(entry: EntryView) -> str:
    return _result(entry.qualified, entry.time_ms, entry.best_completion_pct)


def _result(qualified: bool, time_ms: int | None, completion_pct: float) -> str:
    return seconds(time_ms) if qualified else f"{percent(completion_pct)} done"


def _share(share: float | None) -> str:
    return "" if share is None else f" ({share:.0%})"


def _number(value: float | None) -> str:
    return DASH if value is None else f"{value:g}"


def _flag_text(flags: list[str]) -> str:
    """Which checks flagged a run, in words ("" when none did)."""
    return "; ".join(DESCRIPTIONS.get(flag, flag) for flag in flags)


def _design_rows(record: Record) -> list[tuple[str, str]]:
    """Each design fact, unknown where the run's files do not state it."""
    facts = design_facts(record)
    rows = [(label, fact_text(name, getattr(facts, name), name in facts.unknown))
            for name, label in LABELS.items() if not name.startswith("training")
            and (getattr(facts, name) is not None or name in facts.unknown)]
    hyper = record.design.hyperparameters
    if hyper is None:
        return rows
    shown = {"discount_factor", "lr", "batch_size", "beta_entropy", "num_epochs",
             "num_episodes_between_training", "loss_type"}
    rest = hyper.model_dump(exclude=shown | {"other"}, exclude_none=True) | hyper.other
    rows.extend((name.replace("_", " "), str(value)) for name, value in sorted(rest.items()))
    return rows


def _source_rows(record: Record) -> list[tuple[str, str]]:
    """The file each design fact was read from (none for a record from before they were kept)."""
    sources = record.design.sources
    if sources is None:
        return []
    return [(fact.replace("_", " "), name or UNKNOWN) for fact, name in sources.model_dump().items()]


def _action_space_chart(record: Record) -> charts.Figure | None:
    from . import charts

    space = record.design.action_space
    if space is None:
        return None
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


def _window(board: BoardView, now: datetime) -> str:
    from markupsafe import escape

    if board.status == BoardStatus.UPCOMING and board.opens_at:
        return f"opens {escape(when(board.opens_at))} (in {_until(board.opens_at, now)})"
    if board.status == BoardStatus.OPEN and board.closes_at:
        return f"closes {escape(when(board.closes_at))} (in {_until(board.closes_at, now)})"
    if board.status == BoardStatus.CLOSED and board.closes_at:
        return f"closed {escape(when(board.closes_at))}: the standings are final"
    return "no closing time" if board.status == BoardStatus.OPEN else ""


def _until(moment: datetime, now: datetime) -> str:
    from markupsafe import escape

    left = max(0, int((moment - now).total_seconds()))
    return (f'<time data-until="{escape(moment.isoformat())}" datetime="{escape(moment.isoformat())}">'
            f"{escape(duration(left))}</time>")


def _push_command(board: BoardView, endpoint: str, *, joined: bool) -> str:
    """What a racer types to push here ("" on a closed board). After `drboard join` the board
    is the racer's default one, so the command needs no --endpoint then."""
    if board.status == BoardStatus.CLOSED:
        return ""
    command = "drboard"
    if endpoint and not joined:
        command += f" --endpoint {endpoint}"
    command += " push ./my-model"
    if board.kind == "named":
        command += f" --board {board.board_id}"
    return command
