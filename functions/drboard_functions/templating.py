"""The templates' environment (Jinja2, autoescaped), shared by the web pages (``web``,
``season_page``) and the result cards (``cards.svg``). No model is imported here: the card
function draws a card from a kept page with it alone."""

from __future__ import annotations

from functools import cache
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from jinja2 import Environment


@cache
def environment() -> Environment:
    """The templates' environment, built once per process (autoescape on)."""
    from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

    return Environment(loader=PackageLoader("drboard_functions", "templates"),
                       autoescape=select_autoescape(default=True, default_for_string=True),
                       undefined=StrictUndefined, trim_blocks=False, lstrip_blocks=False)
