"""The Lambda functions' wiring swapped for a service of the test's own (as `drboard serve`
gives the resolvers one): the routes get ``service``, and the pull and card functions' kept pages
are that service's own (its process's copies, and its store's shelf where it has one)."""

from __future__ import annotations

import pytest
from drboard_functions.cards.png import render
from drboard_functions.handlers import wiring
from drboard_functions.routes.kept import KeptCards
from drboard_functions.routes.standings import standings_of
from drboard_functions.service import LeaderboardService


def use_service(monkeypatch: pytest.MonkeyPatch, service: LeaderboardService) -> None:
    monkeypatch.setattr(wiring, "service_from_environment", lambda: service)
    monkeypatch.setattr(wiring, "kept_pages_from_environment", lambda: standings_of(service).pages)
    cards = KeptCards(standings_of(service).pages, render)
    monkeypatch.setattr(wiring, "kept_cards_from_environment", lambda: cards)
