"""Results to analyse, on the pull router (public): a board's laps as CSV, one run's laps as
the metrics JSON deepracer-utils reads, and a racer's submissions over time as CSV."""

from __future__ import annotations

from http import HTTPStatus
from typing import Annotated, Any
from urllib.parse import quote, urlencode

from aws_lambda_powertools.event_handler import Response, content_types
from aws_lambda_powertools.event_handler.openapi.params import Query

from ..laps import HISTORY_COLUMNS, LAP_COLUMNS, csv_text, history_rows
from .params import BoardId, Cursor, OnBoard, RacerAlias, Service, pull_router, segment
from .responses import BAD_PATH, error_response

CSV = "text/csv; charset=utf-8"
SubmissionId = Annotated[str | None, Query(min_length=1, max_length=128,
                                           description="One of the racer's submissions "
                                                       "(default: the one that counts).")]
RunNumber = Annotated[int | None, Query(ge=1, le=1000, description="Which evaluation run of the "
                                        "submission, 1.. (default: the one that scored).")]
CSV_RESPONSE: Any = {"description": "CSV: one header row, UTF-8.",
                     "content": {"text/csv": {"schema": {"type": "string"}}}}
_PRIVATE = "The board keeps its designs, and laps, private until it closes (`DesignsPrivate`)."


def csv_answer(text: str, filename: str, headers: dict[str, str] | None = None) -> Response[str]:
    return Response(status_code=HTTPStatus.OK, content_type=CSV, body=text, headers={
        "Content-Disposition": f"attachment; filename*=UTF-8''{quote(filename, safe='')}",
        "Cache-Control": "no-cache", **(headers or {})})


@pull_router.get(
    "/boards/<board>/laps.csv",
    summary="Every lap of a board's submissions, as CSV",
    description="One row per lap of every evaluation run of every submission: racer, model, "
                "submission, `submitted_at` (ISO 8601, UTC), whether it is the racer's counted "
                "submission, run, lap, `time_s` (seconds), completion, status, off-tracks, "
                "crashes, resets. A page holds the laps of up to 200 submissions; a `Link` "
                "header (`rel=\"next\"`) names the next page, whose CSV has no header row.",
    tags=["results"],
    responses={200: CSV_RESPONSE, 400: error_response("A bad cursor."),
               403: error_response(_PRIVATE), 404: error_response("No such board.")},
)
def board_laps(board: BoardId, service: Service, cursor: Cursor = None) -> Response[str]:
    board_id = segment(board)
    page = service.laps_page(board_id, cursor or None)
    headers = {}
    if page.next_cursor:
        after = f"/boards/{quote(board_id, safe='')}/laps.csv?" + urlencode({"cursor": page.next_cursor})
        headers["Link"] = f'<{after}>; rel="next"'
    return csv_answer(csv_text(LAP_COLUMNS, page.rows, header=not cursor), f"{board_id}-laps.csv",
                      headers)


@pull_router.get(
    "/boards/<board>/racers/<racer>/laps.json",
    summary="One run's laps, as the metrics JSON deepracer-utils reads",
    description="The laps of the racer's counted run (or of run `run` of their submission "
                "`submission`) as an evaluation metrics file, `{\"metrics\": [...]}`: "
                "`TrainingMetrics(None, url=...)` of deepracer-utils loads it.",
    tags=["results"],
    responses={200: {"description": "The run's laps.",
                     "content": {"application/json": {"schema": {"type": "object"}}}},
               400: error_response(BAD_PATH + " Or a run the submission does not have."),
               403: error_response(_PRIVATE),
               404: error_response("No such board, racer or submission.")},
)
def run_laps(board: BoardId, racer: RacerAlias, service: Service, submission: SubmissionId = None,
             run: RunNumber = None) -> Response[Any]:
    metrics = service.run_laps(segment(board), segment(racer), submission, run)
    return Response(status_code=HTTPStatus.OK, content_type=content_types.APPLICATION_JSON,
                    body=metrics)


@pull_router.get(
    "/racers/<racer>/submissions.csv",
    summary="A racer's submissions over time, as CSV",
    description="Every submission of the racer, oldest first (on every board, or on `board`): "
                "`submitted_at`, board, model, whether it qualified, `time_s`, `best_lap_s`, "
                "laps completed, best completion, whether it counts, flags.",
    tags=["results"],
    responses={200: CSV_RESPONSE, 400: error_response(BAD_PATH),
               404: error_response("No such board.")},
)
def racer_submissions_csv(racer: RacerAlias, service: Service, board: OnBoard = None) -> Response[str]:
    name = segment(racer)
    history = service.history(name, segment(board) if board else None)
    return csv_answer(csv_text(HISTORY_COLUMNS, history_rows(history)), f"{name}-submissions.csv")
