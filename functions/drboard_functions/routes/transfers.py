"""The organisers' routes that move a board's contents in and out, or go through all of it: its
export a page at a time, an import (the board, then one submission a request) and the recheck of
its stored runs. A module of their own: the admin function loads them, and the transfer models,
only for a request they answer."""

from __future__ import annotations

import json
from http import HTTPStatus
from typing import Annotated, Any

from aws_lambda_powertools.event_handler import Response, content_types
from aws_lambda_powertools.event_handler.openapi.params import Body
from drboard_assembler import limits

from ..errors import InvalidQuery
from ..models.domain import Board
from ..models.organiser_views import RecheckPage
from ..models.requests import ImportedSubmission
from ..models.transfer import ExportPage, ImportReceipt
from ..models.views import BoardView
from .params import (
    ADMIN_ROUTE,
    BOARD_BODY,
    IMPORT_BODY,
    IMPORT_HEADROOM_BYTES,
    NO_BOARD,
    BoardId,
    Cursor,
    Organiser,
    Service,
    admin_router,
    segment,
    takes,
)
from .responses import admin_responses as _admin_responses
from .responses import json_answer, json_response


@admin_router.get(
    "/boards/<board>/export",
    summary="Export a board, a page at a time",
    description="The first page starts with the board; then come its entries in rank order, "
                "then every submission with its record. Pass the answer's `next_cursor` as "
                "`cursor` until it is null. Deleted boards export too.",
    responses=_admin_responses(json_response("One page of the export.", ExportPage),
                               errors={400: "A bad cursor or board id.", 404: "No such board."}),
    **ADMIN_ROUTE,
)
def export_board(board: BoardId, service: Service, organiser: Organiser,
                 cursor: Cursor = None) -> Response[Any]:
    page = service.export_page(segment(board), cursor or None)
    # Each line as it serialises itself: a stored record goes out as it was stored, unparsed.
    lines = ",".join(line.model_dump_json() for line in page.lines)
    body = f'{{"lines":[{lines}],"next_cursor":{json.dumps(page.next_cursor)}}}'
    return Response(status_code=HTTPStatus.OK, content_type=content_types.APPLICATION_JSON, body=body)


@admin_router.put(
    "/boards/<board>/import",
    status_code=HTTPStatus.CREATED,
    summary="Import a board from an export",
    description="Creates the exported board (its `board_id` must be the path's) unless a board "
                "with that id exists, whose own settings then stay: importing twice changes "
                "nothing. Then replay its submissions with `POST /boards/{board}/imports`.",
    responses=_admin_responses(
        json_response("The board was created.", BoardView), ok_status=HTTPStatus.CREATED,
        body=BOARD_BODY, errors={
            400: "The body's `board_id` is not the path's, or is not a board id.",
            404: "A deleted board has this id: restore it, or import under another id."},
        also={200: json_response("A board with this id exists; it keeps its own settings and "
                                  "nothing changed.", BoardView)}),
    **ADMIN_ROUTE,
)
@takes(BOARD_BODY)
def import_board(board: BoardId,
                 exported: Annotated[Board, Body(description="The `board` of an export's first line.")],
                 service: Service, organiser: Organiser) -> Response[BoardView]:
    board_id = segment(board)
    if exported.board_id != board_id:
        raise InvalidQuery(f"the body is board {exported.board_id!r} but the path names {board_id!r}",
                           detail=[{"loc": "board_id", "msg": f"should be {board_id!r}",
                                    "type": "value_error"}])
    view, created = service.import_board(exported, caller=organiser)
    return json_answer(HTTPStatus.CREATED if created else HTTPStatus.OK, view)


@admin_router.post(
    "/boards/<board>/imports",
    status_code=HTTPStatus.CREATED,
    summary="Replay one exported submission",
    description="Stores the record as first submitted at `submitted_at`, scored by this board's "
                "rules; the board's window and limits do not apply. Importing the same "
                "submission twice changes nothing. The body is bounded at the record's bound plus "
                f"{IMPORT_HEADROOM_BYTES} bytes, and its record at the record's own bound.",
    responses=_admin_responses(
        json_response("The submission was stored.", ImportReceipt), ok_status=HTTPStatus.CREATED,
        body=IMPORT_BODY, errors={
            404: NO_BOARD,
            413: f"The body is over {IMPORT_BODY.max_bytes} bytes, or its record over "
                 f"{limits.MAX_RECORD_BYTES}.",
            422: "The submission is not valid (field-level `detail`), or its run does not "
                 "belong on this board (`BoardMismatch`)."},
        also={200: json_response("The submission was already on the board; nothing changed.",
                                  ImportReceipt)}),
    **ADMIN_ROUTE,
)
@takes(IMPORT_BODY)
def import_submission(board: BoardId,
                      item: Annotated[ImportedSubmission, Body(description="A submission line of "
                                                                           "an export: its record "
                                                                           "and `submitted_at`.")],
                      service: Service, organiser: Organiser) -> Response[ImportReceipt]:
    receipt = service.import_submission(segment(board), item, caller=organiser)
    return json_answer(HTTPStatus.CREATED if receipt.status == "created" else HTTPStatus.OK, receipt)


@admin_router.post(
    "/boards/<board>/recheck",
    summary="Recheck a board's stored runs, a page at a time",
    description="Indexes each stored run for copies and lookalikes (runs stored before the "
                "index), and flags for the organiser the runs another racer pushed first or a "
                "few milliseconds apart (`copied-run`, `near-copy`), aliases that could pass "
                "for another racer's (`lookalike`) and records today's checks would refuse "
                "(`rule-changed`). Nothing is refused or moved. Pass `next_cursor` as `cursor` "
                "until it is null; again, it flags nothing new.",
    responses=_admin_responses(json_response("One page of the recheck.", RecheckPage),
                               errors={400: "A bad cursor or board id.", 404: NO_BOARD}),
    **ADMIN_ROUTE,
)
def recheck_board(board: BoardId, service: Service, organiser: Organiser,
                  cursor: Cursor = None) -> RecheckPage:
    return service.recheck_page(segment(board), cursor or None, caller=organiser)
