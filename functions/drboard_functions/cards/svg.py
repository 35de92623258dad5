"""The cards as SVG (1200×630), from the templates in ``templates/cards/``: every text placed
and fitted here, with the card font's widths (:mod:`.metrics`), so that the PNG rendered from the
SVG (:mod:`.png`) shows each text inside its box."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .content import Podium, RacerCard
from .metrics import FAMILY, Face, fit

WIDTH, HEIGHT = 1200, 630
MARGIN = 60
#: The pages' palette (static/drboard.css): the card reads as the board's own.
COLOURS = {"background": "#0f1720", "text": "#e6edf3", "muted": "#9aa7b4", "link": "#7cc4ff",
           "rule": "#26313d", "gold": "#ffd24d", "gold-text": "#1b1400", "silver": "#d5dde5",
           "silver-text": "#11181f", "bronze": "#f0a868", "bronze-text": "#1d0f02"}
MEDALS = {1: "gold", 2: "silver", 3: "bronze"}


@dataclass(frozen=True)
class Text:
    """One line of text, fitted: where it goes and at what size. ``squeeze`` holds a text the
    font does not wholly cover to its measured width in any renderer (``textLength``)."""

    text: str
    x: float
    y: float
    size: float
    bold: bool
    colour: str
    anchor: str = "start"
    squeeze: float | None = None


def text(value: str, x: float, y: float, *, box: float, size: float, least: float | None = None,
         face: Face = "regular", colour: str = "text", anchor: str = "start") -> Text:
    fitted = fit(value, box, size, least if least is not None else size, face)
    return Text(fitted.text, x, y, fitted.size, face == "bold", COLOURS[colour], anchor,
                None if fitted.covered else round(fitted.width, 1))


def racer_svg(card: RacerCard) -> str:
    """A racer's result: the board, the rank (a medal for the first three), the racer and model,
    the time and the gap to the leader."""
    medal = MEDALS.get(card.rank) if card.leads or (card.rank <= 3 and card.gap) else None
    right = MARGIN + 260
    box = WIDTH - MARGIN - right
    texts = [
        text(card.board_title, MARGIN, 96, box=WIDTH - 2 * MARGIN, size=46, least=28, face="bold"),
        text(card.subtitle, MARGIN, 140, box=WIDTH - 2 * MARGIN, size=26, least=18, colour="muted"),
        text(f"#{card.rank}", MARGIN + 110, 352, box=170, size=84, least=30, face="bold",
             colour=f"{medal}-text" if medal else "text", anchor="middle"),
        text(f"of {card.field}", MARGIN + 110, 480, box=220, size=28, least=18, colour="muted",
             anchor="middle"),
        text(card.racer, right, 260, box=box, size=72, least=34, face="bold"),
        text(card.model_name, right, 312, box=box, size=34, least=20, colour="link"),
        text(card.result_label.upper(), right, 378, box=box, size=24, colour="muted"),
        text(card.result, right, 462, box=box, size=96, least=40, face="bold",
             colour="gold" if card.leads else "text"),
    ]
    if card.gap:
        texts.append(text(card.gap, right, 510, box=box, size=34, least=20,
                          colour="gold" if card.leads else "muted"))
    return _render("racer.svg", texts, card.date, badge={
        "cx": MARGIN + 110, "cy": 322, "r": 100,
        "fill": COLOURS[medal] if medal else COLOURS["rule"]},
        title=f"{card.racer}: #{card.rank} of {card.field} on {card.board_title}, {card.result}")


def podium_svg(podium: Podium) -> str:
    """The first three: each place's medal, name, detail, figure (points) and gap."""
    texts = [
        text(podium.title, MARGIN, 96, box=WIDTH - 2 * MARGIN, size=46, least=28, face="bold"),
        text(podium.subtitle, MARGIN, 140, box=WIDTH - 2 * MARGIN, size=26, least=18, colour="muted"),
    ]
    badges = []
    for row, place in enumerate(podium.places[:3]):
        middle = 236 + row * 112
        medal = MEDALS.get(place.rank)
        badges.append({"cx": MARGIN + 44, "cy": middle, "r": 44,
                       "fill": COLOURS[medal] if medal else COLOURS["rule"]})
        figure = text(place.figure, WIDTH - MARGIN, middle + 6, box=260, size=48, least=28,
                      face="bold", anchor="end")
        name_box = WIDTH - MARGIN - figure_width(figure) - 40 - (MARGIN + 120)
        texts += [
            text(str(place.rank), MARGIN + 44, middle + 16, box=70, size=44, least=24, face="bold",
                 colour=f"{medal}-text" if medal else "text", anchor="middle"),
            text(place.name, MARGIN + 120, middle + 4, box=name_box, size=52, least=26, face="bold"),
            text(place.detail, MARGIN + 120, middle + 40, box=name_box, size=24, least=18,
                 colour="muted"),
            figure,
        ]
        if place.gap:
            texts.append(text(place.gap, WIDTH - MARGIN, middle + 40, box=260, size=24,
                              colour="muted", anchor="end"))
    if not podium.places:
        texts.append(text("No points yet: the podium comes with the first round's results.",
                          MARGIN, 300, box=WIDTH - 2 * MARGIN, size=34, least=20, colour="muted"))
    names = ", ".join(f"{p.rank}. {p.name}" for p in podium.places[:3])
    return _render("podium.svg", texts, podium.date, badges=badges,
                   title=f"{podium.title}: {names or 'no one yet'}")


def figure_width(figure: Text) -> float:
    from .metrics import width

    return width(figure.text, figure.size, "bold" if figure.bold else "regular")


def _render(template: str, texts: list[Text], date: str, **context: Any) -> str:
    from ..templating import environment

    return environment().get_template(f"cards/{template}").render(
        width=WIDTH, height=HEIGHT, margin=MARGIN, colours=COLOURS, family=FAMILY, texts=texts,
        footer=[text("drboard", MARGIN, HEIGHT - 38, box=300, size=30, face="bold"),
                text(date, WIDTH - MARGIN, HEIGHT - 38, box=400, size=26, colour="muted",
                     anchor="end")],
        **context).strip() + "\n"
