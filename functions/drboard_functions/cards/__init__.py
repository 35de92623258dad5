"""Result cards: an image to share a result, 1200×630 (what Discord, Slack and other link
previews show large), named in the pages' Open Graph and Twitter meta.

- :mod:`.content`: what a card says, from the board's views (or a kept page's JSON of them): a
  racer's result (board, rank, time, gap, model) and a podium (a season's first three);
- :mod:`.svg`: the card as SVG, from the templates ``templates/cards/*.svg``, its text fitted
  with the card font's own widths (:mod:`.metrics`);
- :mod:`.png`: the PNG, rendered from that SVG by resvg with the fonts in ``fonts/``
  (Liberation Sans 2, SIL Open Font License 1.1, its licence beside it) and no other: the SVG is
  the one source, so the two cannot disagree, and a card looks the same wherever it is drawn.

The CardFunction serves the card routes in the cloud (resvg and the fonts ship with it only);
`drboard serve` and the embedded board draw the same cards, resvg being a CLI dependency.
"""

from .content import Podium, PodiumPlace, RacerCard, racer_card, racer_card_on_page, season_podium
from .svg import HEIGHT, WIDTH, podium_svg, racer_svg

__all__ = ["HEIGHT", "WIDTH", "Podium", "PodiumPlace", "RacerCard", "podium_svg", "racer_card",
           "racer_card_on_page", "racer_svg", "season_podium"]
