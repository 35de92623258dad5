"""The organisers' routes: boards, moderation, audit and aliases (IAM-signed in the cloud;
answered by ``drboard serve`` only to the computer it runs on). A board's export, import and
recheck are in :mod:`.transfers`."""

from __future__ import annotations

from http import HTTPStatus
from typing import Annotated, Literal

from aws_lambda_powertools.event_handler import Response
from aws_lambda_powertools.event_handler.openapi.params import Body, Query

from ..models.organiser_views import (
    AliasList,
    AliasView,
    AuditPage,
    Moderation,
    RankCounters,
)
from ..models.requests import AliasAssignment, BoardChanges, BoardSpec
from ..models.views import BoardView
from .params import (
    ADMIN_ROUTE,
    ASSIGNMENT_BODY,
    BOARD_BODY,
    CHANGES_BODY,
    DEFAULT_LIMIT,
    NO_BOARD,
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
    **ADMIN_ROUTE,
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
            404: NO_BOARD,
            409: "The change would rescore entries already on the board, or the board is a "
                 "track's default board (`BoardLocked`)."}),
    **ADMIN_ROUTE,
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
                               errors={404: NO_BOARD, 409: _DEFAULT_BOARD}),
    **ADMIN_ROUTE,
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
                               errors={404: NO_BOARD}),
    **ADMIN_ROUTE,
)
def rebuild_ranks(board: BoardId, service: Service, organiser: Organiser) -> RankCounters:
    return service.rebuild_ranks(segment(board), budget_s=REBUILD_BUDGET_S)


@admin_router.delete(
    "/boards/<board>",
    summary="Delete a named board (softly)",
    description="The board disappears from lists, pushes and reads; nothing is erased, and "
                "`POST /boards/{board}/restore` brings it back whole.",
    responses=_admin_responses(json_response("The deleted board.", BoardView),
                               errors={404: NO_BOARD, 409: _DEFAULT_BOARD}),
    **ADMIN_ROUTE,
)
def delete_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.delete_board(segment(board), caller=organiser)


@admin_router.post(
    "/boards/<board>/restore",
    summary="Restore a deleted board",
    description="The board comes back with every entry and submission it had.",
    responses=_admin_responses(json_response("The restored board.", BoardView),
                               errors={404: "No such board."}),
    **ADMIN_ROUTE,
)
def restore_board(board: BoardId, service: Service, organiser: Organiser) -> BoardView:
    return service.restore_board(segment(board), caller=organiser)


@admin_router.delete(
    "/boards/<board>/racers/<racer>",
    summary="Take a racer's entry off a board",
    description="The racer's submissions stay (and show in the audit trail); the standings are "
                "recomputed without them. Their next push makes a new entry.",
    responses=_admin_responses(json_response("What the board now shows of the racer.", Moderation),
                               errors={404: "No such board, or the racer never pushed to it."}),
    **ADMIN_ROUTE,
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
                               errors={404: NO_BOARD}),
    **ADMIN_ROUTE,
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
                               errors={404: NO_BOARD}),
    **ADMIN_ROUTE,
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
    **ADMIN_ROUTE,
)
def get_audit(board: BoardId, service: Service, organiser: Organiser, limit: Limit = DEFAULT_LIMIT,
              cursor: Cursor = None) -> AuditPage:
    return service.audit(segment(board), cursor or None, limit)


# ---- aliases --------------------------------------------------------------------------------


@admin_router.get(
    "/aliases",
    summary="The aliases held and reserved",
    description="Each alias with the sign-in (principal) holding it, or `reserved:<alias>` "
                "while an organiser keeps it for its racer; `limit` at a time, by alias.",
    responses=_admin_responses(json_response("One page of aliases.", AliasList),
                               errors={400: "A bad limit or cursor."}),
    **ADMIN_ROUTE,
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
    **ADMIN_ROUTE,
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
    **ADMIN_ROUTE,
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
    **ADMIN_ROUTE,
)
def release_alias(racer: RacerAlias, service: Service, organiser: Organiser) -> AliasView:
    return service.release_alias(segment(racer), caller=organiser)
