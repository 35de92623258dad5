"""Results to share: the result cards (see :mod:`..cards`), as SVG, and as PNG drawn from it.

The card routes and the CLI's embedded board draw them here; the renderer (resvg) and the cards
are imported on the first card drawn."""

from __future__ import annotations

from typing import Literal

from .boards import Clock
from .reading import Reading
from .seasons import Seasons

CardKind = Literal["png", "svg"]


class Sharing:
    def __init__(self, reading: Reading, seasons: Seasons, clock: Clock) -> None:
        self.reading = reading
        self.seasons = seasons
        self.clock = clock

    def racer_card_svg(self, board_id: str, racer: str) -> str:
        """The racer's result card on the board, as SVG: the board, their rank of how many,
        their time and gap to the leader (the leader's lead), and their model."""
        from .. import cards

        board, entry = self.reading.standing(board_id, racer)
        runner_up = None
        if entry.rank == 1 and entry.qualified:
            second = self.reading.board_page(board_id, limit=2, cursor=None).entries[1:]
            runner_up = second[0] if second else None
        return cards.racer_svg(cards.racer_card(board, entry, runner_up))

    def racer_card(self, board_id: str, racer: str, kind: CardKind = "png") -> bytes:
        """The racer's card as a file: the PNG (1200×630), or its SVG source."""
        return _file(self.racer_card_svg(board_id, racer), kind)

    def season_card_svg(self, season_id: str) -> str:
        """The season's podium card, as SVG: its first three, their points, wins and gaps."""
        from .. import cards

        return cards.podium_svg(cards.season_podium(self.seasons.season(season_id), self.clock()))

    def season_card(self, season_id: str, kind: CardKind = "png") -> bytes:
        """The season's podium card as a file: the PNG, or its SVG source."""
        return _file(self.season_card_svg(season_id), kind)


def _file(svg: str, kind: CardKind) -> bytes:
    if kind == "svg":
        return svg.encode("utf-8")
    from ..cards.png import render

    return render(svg)
