"""The organisers' routes: boards, moderation, audit, export and import (IAM-signed in the
cloud; answered by ``drboard serve`` only to the computer it runs on)."""

from __future__ import annotations

import json
from http import HTTPStatus
from typing import Annotated, Any, Literal

from aws_lambda_powertools.event_handler import Response, content_types
from aws_lambda_powertools.event_handler.openapi.params import Body, Query
from drboard_assembler import limits

from ..errors import InvalidQuery
from ..models.domain import Board
from ..models.organiser_views import (
    AliasList,
    AliasView,
    AuditPage,
    Moderation,
    RankCounters,
    RecheckPage,
)
from ..models.requests import AliasAssignment, BoardChanges, BoardSpec, ImportedSubmission
from ..models.transfer import ExportPage, ImportReceipt
from ..models.views import BoardView
from .params import (
    ADMIN_TAG,
    ASSIGNMENT_BODY,
    BOARD_BODY,
    CHANGES_BODY,
    DEFAULT_LIMIT,
    IMPORT_BODY,
    IMPORT_HEADROOM_BYTES,
    SIGV4,
    BoardId,
    Cursor,
    Limit,
    Organiser,
    RacerAlias,
    ReplaceHolder,
    Service,
    admin_router,
    segment,
    takes,
)
from .responses import admin_responses as _admin_responses
from .responses import json_answer, json_response

BanScope = Annotated[Literal["event", "board"], Query(
    description="`event` (default): every board of the deployment; `board`: this board only.")]

_ADMIN: dict[str, Any] = {"cors": False, "tags": [ADMIN_TAG], "security": [{SIGV4: []}]}
_NO_BOARD = "No such board (or it was deleted)."
_DEFAULT_BOARD = ("The board is a track's default board, which keeps the default rules "
                  "(`BoardLocked`).")


@admin_router.post(
    "/boards",
    status_code=HTTPStatus.CREATED,
    summary="Create a named board",
    description="A board of the organiser's own on a track, with its title, timing method, window "
                "(`opens_at`, `closes_at`) and limits (`cooldown_s` between a racer's "
                "submissions, `max_submissions` per racer). Racers push to it by its id.",
    responses=_admin_responses(
        json_response("The board was created.", BoardView), ok_status=HTTPStatus.CREATED,
        body=BOARD_BODY, errors={
            400: "An unknown or ambiguous track (the closest matches are listed), a window that "
                 "closes before it opens, or a bad board id.",
            409: "A board with this id exists, or the id is a track's default board's "
                 "(`BoardExists`)."}),
    **_ADMIN,
)
@takes(BOARD_BODY)
def create_board(spec: Annotated[BoardSpec, Body(description="The new board.")],
                 service: Service, organiser: Organiser) -> Response[BoardView]:
    return json_answer(HTTPStatus.CREATED, service.create_board(spec, caller=organiser))


@admin_router.patch(
    "/boards/<board>",
    summary="Change a named board",
    description="Only the fields in the body change; `null` clears a window's end or a limit. "
                "The timing method and minimum laps change only while the board has no entries.",
    responses=_admin_responses(
        json_response("The board as it is now.", BoardView), body=CHANGES_BODY, errors={
            400: "The title or method cleared, a window that closes before it opens, or a bad "
                 "board id.",
            404: _NO_BOARD,
            409: "The change would rescore entries already on the board, or the board is a "
                 "track's default board (`BoardLocked`)."}),
    **_ADMIN,
)
@takes(CHANGES_BODY)
def update_board(board: BoardId,
                 changes: Annotated[BoardChanges, Body(description="The fields to change.")],
                 service: Service, organiser: Organiser) -> BoardView:
    return service.update_board(segment(board), changes, caller=organiser)


@admin_router.post(
    "/boards/<board>/close",
    summary="Close a named board now",
    description="Pushes are refused from now on (`BoardClosed`); an upcoming board closes "
                "without ever opening. Closing a closed board changes nothing.",
    responses=_admin_responses(json_response("The closed board.", BoardView),
                               errors={404: _NO_BOARD, 409: _DEFAULT_BOARD}),
    **_ADMIN,
)
def close_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.close_board(segment(board), caller=organiser)


#: How long one request builds rank counters: well within the function's timeout.
REBUILD_BUDGET_S = 5.0


@admin_router.post(
    "/boards/<board>/rank-counters",
    summary="Build a board's rank counters",
    description="A board from before the rank counters ranks by counting its better entries "
                "until its counters are built. Each request counts entries for a few seconds "
                "and says how far it got; ask again until `done` (a stopped build goes on where "
                "it stopped). A board that has its counters answers `done` at once.",
    responses=_admin_responses(json_response("How far the build got.", RankCounters),
                               errors={404: _NO_BOARD}),
    **_ADMIN,
)
def rebuild_ranks(board: BoardId, service: Service, organiser: Organiser) -> RankCounters:
    return service.rebuild_ranks(segment(board), budget_s=REBUILD_BUDGET_S)


@admin_router.delete(
    "/boards/<board>",
    summary="Delete a named board (softly)",
    description="The board disappears from lists, pushes and reads; nothing is erased, and "
                "`POST /boards/{board}/restore` brings it back whole.",
    responses=_admin_responses(json_response("The deleted board.", BoardView),
                               errors={404: _NO_BOARD, 409: _DEFAULT_BOARD}),
    **_ADMIN,
)
def delete_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.delete_board(segment(board), caller=organiser)


@admin_router.post(
    "/boards/<board>/restore",
    summary="Restore a deleted board",
    description="The board comes back with every entry and submission it had.",
    responses=_admin_responses(json_response("The restored board.", BoardView),
                               errors={404: "No such board."}),
    **_ADMIN,
)
def restore_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.restore_board(segment(board), caller=organiser)


@admin_router.get(
    "/boards/<board>/export",
    summary="Export a board, a page at a time",
    description="The first page starts with the board; then come its entries in rank order, "
                "then every submission with its record. Pass the answer's `next_cursor` as "
                "`cursor` until it is null. Deleted boards export too.",
    responses=_admin_responses(json_response("One page of the export.", ExportPage),
                               errors={400: "A bad cursor or board id.", 404: "No such board."}),
    **_ADMIN,
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
    **_ADMIN,
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
            404: _NO_BOARD,
            413: f"The body is over {IMPORT_BODY.max_bytes} bytes, or its record over "
                 f"{limits.MAX_RECORD_BYTES}.",
            422: "The submission is not valid (field-level `detail`), or its run does not "
                 "belong on this board (`BoardMismatch`)."},
        also={200: json_response("The submission was already on the board; nothing changed.",
                                  ImportReceipt)}),
    **_ADMIN,
)
@takes(IMPORT_BODY)
def import_submission(board: BoardId,
                      item: Annotated[ImportedSubmission, Body(description="A submission line of "
                                                                           "an export: its record "
                                                                           "and `submitted_at`.")],
                      service: Service, organiser: Organiser) -> Response[ImportReceipt]:
    receipt = service.import_submission(segment(board), item, caller=organiser)
    return json_answer(HTTPStatus.CREATED if receipt.status == "created" else HTTPStatus.OK, receipt)


@admin_router.delete(
    "/boards/<board>/racers/<racer>",
    summary="Take a racer's entry off a board",
    description="The racer's submissions stay (and show in the audit trail); the standings are "
                "recomputed without them. Their next push makes a new entry.",
    responses=_admin_responses(json_response("What the board now shows of the racer.", Moderation),
                               errors={404: "No such board, or the racer never pushed to it."}),
    **_ADMIN,
)
def remove_entry(board: BoardId, racer: RacerAlias, service: Service,
                 organiser: Organiser) -> Moderation:
    return service.remove_entry(segment(board), segment(racer), caller=organiser)


@admin_router.put(
    "/boards/<board>/bans/<racer>",
    summary="Ban a racer",
    description="The racer's pushes are refused (`Banned`): by their alias, and by the sign-in "
                "holding it whatever alias it pushes as; on every board of the event (the "
                "deployment) unless `scope=board`. Their entry comes off this board; their "
                "submissions stay, and `DELETE` on the same path puts their best back.",
    responses=_admin_responses(json_response("The racer is banned.", Moderation),
                               errors={404: _NO_BOARD}),
    **_ADMIN,
)
def ban_racer(board: BoardId, racer: RacerAlias, service: Service, organiser: Organiser,
              scope: BanScope = "event") -> Moderation:
    return service.ban(segment(board), segment(racer), caller=organiser,
                       everywhere=scope == "event")


@admin_router.delete(
    "/boards/<board>/bans/<racer>",
    summary="Lift a racer's ban",
    description="The racer may push again (their bans on this board and across the event are "
                "lifted), and their best submission is back on the board.",
    responses=_admin_responses(json_response("The racer is no longer banned.", Moderation),
                               errors={404: _NO_BOARD}),
    **_ADMIN,
)
def unban_racer(board: BoardId, racer: RacerAlias, service: Service,
                organiser: Organiser) -> Moderation:
    return service.unban(segment(board), segment(racer), caller=organiser)


@admin_router.get(
    "/boards/<board>/audit",
    summary="A board's audit trail",
    description="Every accepted push and every organiser action on the board, oldest first: "
                "who (`actor`), when, what. Pass `next_cursor` as `cursor` for the next page.",
    responses=_admin_responses(json_response("One page of the audit trail.", AuditPage),
                               errors={400: "A bad limit or cursor.", 404: "No such board."}),
    **_ADMIN,
)
def get_audit(board: BoardId, service: Service, organiser: Organiser, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None) -> AuditPage:
    return service.audit(segment(board), cursor or None, limit)


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
                               errors={400: "A bad cursor or board id.", 404: _NO_BOARD}),
    **_ADMIN,
)
def recheck_board(board: BoardId, service: Service, organiser: Organiser,
                  cursor: Cursor = None) -> RecheckPage:
    return service.recheck_page(segment(board), cursor or None, caller=organiser)


# ---- aliases --------------------------------------------------------------------------------


@admin_router.get(
    "/aliases",
    summary="The aliases held and reserved",
    description="Each alias with the sign-in (principal) holding it, or `reserved:<alias>` "
                "while an organiser keeps it for its racer; `limit` at a time, by alias.",
    responses=_admin_responses(json_response("One page of aliases.", AliasList),
                               errors={400: "A bad limit or cursor."}),
    **_ADMIN,
)
def list_aliases(service: Service, organiser: Organiser, limit: Limit = DEFAULT_LIMIT,
                 cursor: Cursor = None) -> AliasList:
    return service.aliases(limit, cursor or None)


@admin_router.get(
    "/aliases/audit",
    summary="The aliases' audit trail",
    description="Every reservation, assignment and release of an alias: who, when, what.",
    responses=_admin_responses(json_response("One page of the trail.", AuditPage),
                               errors={400: "A bad limit or cursor."}),
    **_ADMIN,
)
def alias_audit(service: Service, organiser: Organiser, limit: Limit = DEFAULT_LIMIT,
                cursor: Cursor = None) -> AuditPage:
    return service.alias_audit(cursor or None, limit)


@admin_router.put(
    "/aliases/<racer>",
    summary="Reserve an alias, or give it to a sign-in",
    description="With no `principal`, the alias is kept for its racer: no one claims it until "
                "an organiser gives it out (an alias someone holds stays theirs). With a "
                "`principal` (a sign-in, as `GET /me` names it), the alias is that sign-in's; "
                "one another sign-in holds moves only with `replace=true`. Again changes nothing.",
    responses=_admin_responses(
        json_response("Who holds the alias now.", AliasView), body=ASSIGNMENT_BODY, errors={
            400: "The alias is not one a racer may take, or the principal is not a sign-in.",
            403: "Another sign-in holds the alias (`AliasTaken`): give `replace=true`. "
                 "Or the caller does not organise."}),
    **_ADMIN,
)
@takes(ASSIGNMENT_BODY)
def assign_alias(racer: RacerAlias,
                 assignment: Annotated[AliasAssignment, Body(description="Who gets the alias.")],
                 service: Service, organiser: Organiser, replace: ReplaceHolder = False) -> AliasView:
    return service.assign_alias(segment(racer), assignment.principal, replace, caller=organiser)


@admin_router.delete(
    "/aliases/<racer>",
    summary="Release an alias",
    description="The alias leaves its sign-in (or its reservation): the next racer to claim it "
                "takes it, unless it has results, which only an organiser gives out.",
    responses=_admin_responses(json_response("The claim that was released.", AliasView),
                               errors={404: "No one holds the alias."}),
    **_ADMIN,
)
def release_alias(racer: RacerAlias, service: Service, organiser: Organiser) -> AliasView:
    return service.release_alias(segment(racer), caller=organiser)
