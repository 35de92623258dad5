"""A season's web page (``templates/season.html``) and the list of seasons
(``templates/seasons.html``), rendered as the other pages are (:mod:`.web`: the same templates'
environment, style sheet and Content-Security-Policy).

The page shows the standings (rank, racer, points, each round's place and points, the rounds
that do not count struck out, the final's qualifiers marked Q), the points table and the
tie-breaks, and the rounds with links to their boards. ``?screen=1`` is its big-screen mode: a
projector's page of racers at a time in type sized from the screen (the more rounds, the
smaller), the next page after a while (its one small script, ``static/season-screen.js``,
allowed by its hash; without script a link), and a QR code of the page.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import datetime
from functools import cache
from importlib.resources import files
from typing import Any
from urllib.parse import urlencode

from . import web
from .display import ordinal, plural, points_rule, points_text
from .models.domain import BoardStatus
from .models.seasons import RoundView, SeasonStandings, SeasonSummary, Standing
from .templating import environment

#: Racers on one page of the big screen, and how long it shows before the next.
SCREEN_ROWS = 15
SCREEN_HOLD_S = 15
#: With one page, how often the big screen shows the standings afresh.
SCREEN_REFRESH_S = 30
#: The big screen's type buckets (the style sheet's ``fit-N``): up to N rounds.
_FITS = ((8, ""), (12, "fit-12"), (18, "fit-18"))
_WIDEST = "fit-30"


@dataclass(frozen=True)
class Page:
    html: str
    content_security_policy: str


@cache
def _screen_script() -> str:
    return (files("drboard_functions") / "static" / "season-screen.js").read_text("utf-8")


def _policy(script: bool) -> str:
    policy = web.content_security_policy(live=False)
    return policy + (f"; script-src '{web.csp_hash(_screen_script())}'" if script else "")


def _render(template: str, *, heading: str, subtitle: str, screen: bool = False,
            **context: Any) -> str:
    """A page on the templates' ``base.html``, as :mod:`.web` renders its own (never live)."""
    return environment().get_template(template).render(
        title=f"{heading} · drboard", heading=heading, subtitle=subtitle, live=None, screen=screen,
        refresh_s=web.REFRESH_S, assets=web.assets(), **context)


def season_page(view: SeasonStandings, *, screen: bool = False, part: int = 1,
                url: str = "", origin: str = "") -> Page:
    """``/seasons/{season}/view``: the whole standings (up to a page of the API's), or on the
    big screen the ``part``-th page of ``SCREEN_ROWS`` racers, with a QR code of ``url``. Its
    Open Graph meta name the season's podium card (absolute URLs, on ``origin``)."""
    season = view.season
    rows = view.standings
    path = web.season_path(season.season_id)
    shown = ""
    next_screen = None
    hold_s = SCREEN_REFRESH_S
    if screen:
        parts = max(1, math.ceil(len(rows) / SCREEN_ROWS))
        part = min(max(1, part), parts)
        first = (part - 1) * SCREEN_ROWS
        if parts > 1:
            shown = f"racers {first + 1} to {min(first + SCREEN_ROWS, len(rows))} of {len(rows)}"
            hold_s = SCREEN_HOLD_S
        rows = rows[first:first + SCREEN_ROWS]
        following = part % parts + 1
        next_screen = path + "?" + urlencode({"screen": 1, **({"part": following} if parts > 1 else {})})
    final = None
    if season.final is not None:
        source = (f"round {_round_number(season.rounds, season.final.from_round)}"
                  if season.final.from_round else "the season")
        final = {"title": season.final.title, "path": web.board_path(season.final.board_id),
                 "text": f"The final takes the top {season.final.top} of {source}"}
    racers = (plural(len(view.standings), "racer") if view.next_cursor is None
              else f"{len(view.standings)}+ racers")
    html = _render(
        "season.html", heading=season.title, screen=screen, season=season,
        fit=_fit(len(season.rounds)) if screen else "",
        screen_script=_screen_script(), hold_s=hold_s, next_screen=next_screen, shown=shown,
        status_class=season.status.lower(), status_text="Running" if season.status == "OPEN" else "Ended",
        subtitle=" · ".join(bit for bit in (
            plural(len(season.rounds), "round"), racers, shown) if bit),
        points_rule=points_rule(season.points, season.best_of, season.rounds),
        final=final, rounds=[_round(r) for r in season.rounds],
        rows=[_row(s) for s in rows],
        next_page=(path + "?" + urlencode({"cursor": view.next_cursor})
                   if view.next_cursor and not screen else None),
        screen_path=path + "?screen=1", podium_path=web.podium_path(season.season_id),
        qr={"svg": web.qr_svg(url), "url": url} if screen and url else None,
        share=_share(view, origin, path),
    )
    return Page(html, _policy(script=next_screen is not None))


def podium_page(view: SeasonStandings, *, origin: str, now: datetime) -> Page:
    """``/seasons/{season}/podium/view``: the season's podium card, and a certificate for each
    racer of its first three ranks, which print one to an A4 landscape page."""
    from .cards.content import points, season_podium, standing_detail

    season = view.season
    podium = season_podium(view, now)
    places = {1: "First place", 2: "Second place", 3: "Third place"}
    medals = {1: "gold", 2: "silver", 3: "bronze"}
    certificates = [{"rank": s.rank, "place": places[s.rank], "medal": medals[s.rank], "name": s.racer,
                     "result": points(s.points, "point"),
                     "detail": standing_detail(s) + (" · qualified for the final"
                                                     if s.qualified_for_final else ""),
                     "date": (season.closed_at or now).strftime("%Y-%m-%d")}
                    for s in view.standings if s.rank in places]
    path = web.podium_path(season.season_id)
    html = _render("podium.html", heading=f"Podium · {season.title}", subtitle=podium.subtitle,
                   certificates=certificates, season_title=season.title,
                   season_path=web.season_path(season.season_id),
                   share=_share(view, origin, path))
    return Page(html, _policy(script=False))


def _share(view: SeasonStandings, origin: str, path: str) -> web.Share:
    """The Open Graph and Twitter meta of a season's pages: its podium card."""
    season = view.season
    top = [s for s in view.standings if s.rank <= 3]
    said = ", ".join(f"{ordinal(s.rank)} {s.racer} ({points_text(s.points)} pts)" for s in top)
    card = web.season_card_path(season.season_id)
    return web.Share(
        title=f"{season.title}: " + ("final standings" if season.status == "CLOSED" else "standings"),
        description=(said or "No points yet") + f" · {plural(len(season.rounds), 'round')}.",
        url=origin + path, image=origin + card, alt=f"Podium card of {season.title}: {said or 'no one yet'}",
        card_path=card, svg_path=web.season_card_path(season.season_id, "svg"))


def seasons_page(seasons: list[SeasonSummary]) -> Page:
    """``/seasons/view``: every season, running and past."""
    listed = [{"path": web.season_path(s.season_id), "title": s.title, "rounds": s.rounds,
               "status_class": s.status.lower(), "status_text": "Running" if s.status == "OPEN" else "Ended"}
              for s in seasons]
    return Page(_render("seasons.html", heading="Seasons",
                        subtitle="Race nights added up: the running seasons and the past ones.",
                        seasons=listed), _policy(script=False))


def _fit(rounds: int) -> str:
    """The big screen's type bucket for this many rounds."""
    return next((fit for most, fit in _FITS if rounds <= most), _WIDEST)


def _round_number(rounds: list[RoundView], board_id: str | None) -> str:
    found = next((r for r in rounds if r.board_id == board_id), None)
    return f"R{found.number} ({found.title})" if found else str(board_id)


def _round(r: RoundView) -> dict[str, Any]:
    states = {BoardStatus.OPEN: "open", BoardStatus.UPCOMING: "not open yet",
              BoardStatus.CLOSED: "closed"}
    missing = r.status == "MISSING"
    return {"number": r.number, "title": r.title, "path": None if missing else web.board_path(r.board_id),
            "weight_text": f"×{r.weight:g}" if r.weight != 1 else "", "always_counts": r.always_counts,
            "state": "board deleted: its results do not count" if missing else
                     f"{states[BoardStatus(r.status)]}, {plural(r.participants, 'racer')}"}


def _row(standing: Standing) -> dict[str, Any]:
    css = [f"q{standing.rank}"] if standing.rank <= 3 else []
    if standing.qualified_for_final:
        css.append("qualified")
    finishes = []
    for number, score in enumerate(standing.rounds, start=1):
        if score.rank is None:
            finishes.append({"number": number, "css": "absent", "place": "", "points": "—",
                             "dropped": False})
            continue
        finishes.append({"number": number, "css": "counted" if score.counted else "dropped",
                         "place": ordinal(score.rank) if score.qualified else "DNQ",
                         "points": points_text(score.points), "dropped": not score.counted})
    return {"rank": standing.rank, "racer": standing.racer, "points": points_text(standing.points),
            "qualified": standing.qualified_for_final, "css": " ".join(css), "finishes": finishes}
