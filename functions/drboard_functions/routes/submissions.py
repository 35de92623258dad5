"""A racer's submission and sign-in: the push router (IAM-signed in the cloud)."""

from __future__ import annotations

from http import HTTPStatus
from typing import Annotated, Any

from aws_lambda_powertools.event_handler import Response, content_types
from aws_lambda_powertools.event_handler.openapi.params import Body
from drboard_assembler import limits
from drboard_assembler.record import Record

from ..models.requests import AliasRequest
from ..models.views import Me, PushAccepted, PushReceipt
from .params import ALIAS_BODY, RECORD_BODY, SIGV4, BoardId, Service, SignedIn, push_router, segment, takes
from .responses import BAD_PATH, UNREADABLE, UNSIGNED, error_response, json_response


@push_router.post(
    "/boards/<board>/submissions",
    cors=False,
    status_code=HTTPStatus.CREATED,
    summary="Submit a run",
    description="Validates the record (derived figures, submission id, plausible laps) and stores "
                "it on the board. 201 for a new submission, 200 when the same run was already "
                "submitted (nothing changes, whatever the board's window and limits). Requests "
                "must be signed with SigV4 (IAM).",
    tags=["submissions"],
    security=[{SIGV4: []}],
    responses={
        201: json_response("The submission was stored.", PushReceipt),
        200: json_response("The same run was already submitted; nothing changed.", PushReceipt),
        202: json_response("The submission was stored, but its rank could not be read back "
                           "just then: read it at `receipt` (pushing the run again answers "
                           "it as a duplicate).", PushAccepted),
        400: error_response(BAD_PATH + UNREADABLE),
        401: error_response("No sign-in the board accepts (`NotSignedIn`)."),
        403: error_response("The board is not open (`BoardClosed`: it opens later or has "
                             "closed), the racer has made every submission it allows "
                             "(`SubmissionLimitReached`), the alias is another racer's, kept "
                             "by the organiser, has results pushed without a sign-in, could "
                             "pass for another racer's on the board, or the caller pushes as "
                             "another alias (`AliasTaken`), or the racer or their sign-in is "
                             "banned (`Banned`). " + UNSIGNED),
        409: error_response("The run's laps were first pushed by another racer, on this or "
                             "any board (`CopiedRun`)."),
        404: error_response("No such board, and the run's own board is another one."),
        413: error_response(f"The body is over {limits.MAX_RECORD_BYTES} bytes."),
        415: error_response("The body is not JSON (`UnsupportedBody` for a multipart one)."),
        422: error_response("The record is invalid or does not belong on this board."),
        429: {**error_response("The board's cooldown applies (`TooSoon`); see Retry-After."),
              "headers": {"Retry-After": {"description": "Seconds to wait.",
                                          "schema": {"type": "integer"}}}},
    },
)
@takes(RECORD_BODY)
def submit(
    board: BoardId,
    record: Annotated[Record, Body(description="The record `drboard assemble` builds.")],
    service: Service,
    caller: SignedIn,
) -> Response[Any]:
    # Encoded once, here: the receipt's model is the service's own, so no response validation
    # or second serialisation (the statuses' schemas are documented in `responses` above).
    receipt = service.push(record, segment(board), caller=caller)
    if isinstance(receipt, PushAccepted):
        status = HTTPStatus.ACCEPTED
    else:
        status = HTTPStatus.CREATED if receipt.status == "created" else HTTPStatus.OK
    return Response(status_code=int(status), content_type=content_types.APPLICATION_JSON,
                    body=receipt.model_dump_json())


# The record's schema is deferred (a function that takes no record never builds it). The route's
# body adapter wraps it: built first, it is built once; else the adapter builds it inline, and the
# record's own checks build it again on the first push (~4 ms of a cold start).
Record.model_rebuild()


# ---- the signed-in caller -------------------------------------------------------------------------


@push_router.get(
    "/me",
    cors=False,
    summary="Who the board takes you for",
    description="The caller's sign-in and the alias it holds (null before the first push or "
                "`PUT /me/alias`).",
    tags=["racers"],
    security=[{SIGV4: []}],
    responses={200: json_response("The caller.", Me),
               401: error_response("No sign-in the board accepts (`NotSignedIn`).")},
)
def get_me(service: Service, caller: SignedIn) -> Me:
    return service.me(caller)


@push_router.put(
    "/me/alias",
    cors=False,
    summary="Claim your racer alias",
    description="Binds the alias to the caller's sign-in, once: aliases are compared after "
                "Unicode NFKC and case folding, and one holding invisible characters or mixing "
                "lookalike scripts is refused. A racer's first push claims its alias too.",
    tags=["racers"],
    security=[{SIGV4: []}],
    responses={200: json_response("The caller, with the alias.", Me),
               400: error_response("The alias is not one a racer may take."),
               401: error_response("No sign-in the board accepts (`NotSignedIn`)."),
               403: error_response("The alias is another racer's, or the caller holds another "
                                    "(`AliasTaken`)."),
               413: error_response(f"The body is over {ALIAS_BODY.max_bytes} bytes."),
               415: error_response("The body is not JSON."),
               422: error_response("The body is not `{\"alias\": ...}`.")},
)
@takes(ALIAS_BODY)
def put_my_alias(request: Annotated[AliasRequest, Body(description="The alias to claim.")],
                 service: Service, caller: SignedIn) -> Me:
    return service.claim_alias(request.alias, caller=caller)
