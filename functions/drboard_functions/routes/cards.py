"""The result cards, on the card router (public; the CardFunction's in the cloud): a racer's
result, and a season's podium, as SVG and as PNG, at stable addresses the pages name in their
Open Graph meta.

A card answers with an ``ETag`` of its SVG (the PNG is drawn from it), so a client that holds
the card as it stands is answered ``304`` before anything is drawn. In the cloud the card function
draws a racer's card from the standings kept for the board's version before it loads these
routes (see ``routes.kept.KeptCards``). The cards and their renderer
are imported on the first card a process draws (the pull function never does)."""

from __future__ import annotations

import base64
from http import HTTPStatus
from typing import Any

from aws_lambda_powertools.event_handler import Response

from .headers import PNG, SVG, SVG_POLICY, card_etag, card_headers, names_etag
from .params import BoardId, IfNoneMatch, RacerAlias, SeasonId, Service, card_router, segment
from .responses import BAD_PATH, error_response

SIZE = "1200×630"  # cards.WIDTH × cards.HEIGHT
_NOT_FOUND = "No such board, or no such racer on it."


def card_response(kind: str) -> Any:
    schema = {"type": "string", "format": "binary"} if kind == "png" else {"type": "string"}
    return {"description": f"The card, {SIZE} ({kind.upper()}), with an ETag.",
            "content": {{"svg": SVG, "png": PNG}[kind]: {"schema": schema}}}


def card_answer(svg: str, kind: str, if_none_match: str | None) -> Response[str]:
    """The card as SVG or PNG (drawn only when the client does not hold it already)."""
    etag = card_etag(svg, kind)
    headers = card_headers(etag)
    if names_etag(if_none_match, etag):
        return Response(status_code=HTTPStatus.NOT_MODIFIED, headers=headers, body="")
    if kind == "svg":
        return Response(status_code=HTTPStatus.OK, content_type=SVG, body=svg,
                        headers=headers | SVG_POLICY)
    from ..cards.png import render

    # API Gateway carries a binary body as base64: said here, since the route's answer is
    # validated as text before Powertools would encode bytes itself
    answer = Response(status_code=HTTPStatus.OK, content_type=PNG,
                      body=base64.b64encode(render(svg)).decode("ascii"), headers=headers)
    answer.base64_encoded = True
    return answer


def _responses(kind: str, missing: str = _NOT_FOUND) -> Any:
    return {200: card_response(kind), 304: {"description": "The client holds this card already."},
            400: error_response(BAD_PATH), 404: error_response(missing)}


@card_router.get(
    "/boards/<board>/racers/<racer>/card.svg",
    summary="A racer's result card, as SVG",
    description="The board, the racer's rank (of how many), their time and gap to the leader, "
                "and their model, 1200×630: the source the PNG is drawn from.",
    tags=["cards"],
    responses=_responses("svg"),
)
def racer_card_svg(board: BoardId, racer: RacerAlias, service: Service,
                   if_none_match: IfNoneMatch = None) -> Response[str]:
    return card_answer(service.racer_card_svg(segment(board), segment(racer)), "svg", if_none_match)


@card_router.get(
    "/boards/<board>/racers/<racer>/card.png",
    summary="A racer's result card, as PNG",
    description="The SVG card drawn as a 1200×630 PNG: what the racer page's `og:image` names, "
                "so a link to the page pasted in a chat unfurls as the card.",
    tags=["cards"],
    responses=_responses("png"),
)
def racer_card_png(board: BoardId, racer: RacerAlias, service: Service,
                   if_none_match: IfNoneMatch = None) -> Response[str]:
    return card_answer(service.racer_card_svg(segment(board), segment(racer)), "png", if_none_match)


@card_router.get(
    "/seasons/<season>/card.svg",
    summary="A season's podium card, as SVG",
    description="The season's first three: their points, wins, rounds raced and gap to the "
                "leader, 1200×630: the source the PNG is drawn from.",
    tags=["cards"],
    responses=_responses("svg", "No such season."),
)
def season_card_svg(season: SeasonId, service: Service, if_none_match: IfNoneMatch = None) -> Response[str]:
    return card_answer(service.season_card_svg(segment(season)), "svg", if_none_match)


@card_router.get(
    "/seasons/<season>/card.png",
    summary="A season's podium card, as PNG",
    description="The SVG card drawn as a 1200×630 PNG: what the season page's and its podium "
                "page's `og:image` name.",
    tags=["cards"],
    responses=_responses("png", "No such season."),
)
def season_card_png(season: SeasonId, service: Service, if_none_match: IfNoneMatch = None) -> Response[str]:
    return card_answer(service.season_card_svg(segment(season)), "png", if_none_match)
