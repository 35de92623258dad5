"""A deployed board (or `drboard serve`) over HTTP: the same calls as the in-process board.

Every ``BoardClient`` call maps to one route (see the README's HTTP API). Pushes and every
organiser call carry the sign-in token saved for the endpoint (:mod:`drboard_cli.tokens`; a
Cognito one goes to the same route under ``/cognito``, renewed first when it is about to expire)
or, with none, are signed with SigV4 using the caller's AWS credentials when there are any; reads
are public.
An error answer becomes the domain error the board named in its ``error`` field, so a refusal
reads the same as on the in-process board; an answer without one (API Gateway's own, e.g. 403
for an unsigned request) is mapped by its status.
"""

from __future__ import annotations

import csv
import io
import json
import re
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

from drboard_assembler.record import Record
from drboard_functions import errors
from drboard_functions.laps import LAP_COLUMNS
from drboard_functions.models.domain import MAX_PAGE, Board
from drboard_functions.models.notices import Delivery, TargetKind, WebhookList, WebhookSpec, WebhookView
from drboard_functions.models.organiser_views import (
    AliasList,
    AliasView,
    AuditPage,
    Moderation,
    RankCounters,
    RecheckPage,
)
from drboard_functions.models.racer_views import (
    Comparison,
    Insights,
    RacerHistory,
    RacerSummary,
    RacerView,
)
from drboard_functions.models.requests import (
    AliasAssignment,
    AliasRequest,
    BoardChanges,
    BoardSpec,
    ImportedSubmission,
)
from drboard_functions.models.seasons import (
    FinalSpec,
    RoundSpec,
    SeasonChanges,
    SeasonList,
    SeasonSpec,
    SeasonStandings,
    SeasonSummary,
)
from drboard_functions.models.transfer import ExportKind, ExportPage, ImportReceipt
from drboard_functions.models.views import (
    BoardList,
    BoardPage,
    BoardView,
    HistoryItem,
    Me,
    PushAccepted,
    PushReceipt,
)
from drboard_functions.service import default_board_id
from drboard_functions.service.results import LapsPage
from pydantic import BaseModel, ValidationError

from . import tokens
from .joins import Joined, JoinRequest
from .login import fresh_token

T = TypeVar("T", bound=BaseModel)
P = TypeVar("P", BoardList, RacerHistory, RacerView, SeasonList)

TIMEOUT_S = 20
DEFAULT_RETRY_AFTER_S = 60
_API_REGION = re.compile(r"\.execute-api\.([a-z0-9-]+)\.")


@dataclass(frozen=True)
class Answer:
    status: int
    body: Any
    headers: Mapping[str, str] | None = None  # case-insensitive (http.client.HTTPMessage)


class HttpBoard:
    def __init__(self, endpoint: str, timeout_s: float = TIMEOUT_S) -> None:
        self.endpoint = endpoint.rstrip("/")
        self.timeout_s = timeout_s

    # ---- racers -------------------------------------------------------------------------

    def push(self, record: Record, board_id: str | None) -> PushReceipt | PushAccepted:
        board = board_id or default_board_id(record.track, record.direction, record.race_type)
        answer = self._call("POST", f"/boards/{_quote(board)}/submissions", body=record, signed=True)
        if answer.status == 202:  # stored; its rank could not be read back just then
            return _parse(PushAccepted, answer)
        return _parse(PushReceipt, answer)

    def boards(self) -> list[BoardView]:
        """Every board, following the pages."""
        return [board for page in self._pages(BoardList, "/boards", {}) for board in page.boards]

    def board_page(self, board_id: str, limit: int, cursor: str | None) -> BoardPage:
        query = {"limit": str(limit), "cursor": cursor}
        return _parse(BoardPage, self._call("GET", f"/boards/{_quote(board_id)}", query=query))

    def racer(self, board_id: str, racer: str) -> RacerView:
        """The racer's entry and record, with their whole history on the board."""
        path = f"/boards/{_quote(board_id)}/racers/{_quote(racer)}"
        pages = list(self._pages(RacerView, path, {}))
        history = [item for page in pages for item in page.history]
        return pages[0].model_copy(update={"history": history, "next_cursor": None})

    def compare(self, board_id: str, racers: Sequence[str]) -> Comparison:
        answer = self._call("GET", f"/boards/{_quote(board_id)}/compare", query={"racer": list(racers)})
        return _parse(Comparison, answer)

    def insights(self, board_id: str, top: int) -> Insights:
        answer = self._call("GET", f"/boards/{_quote(board_id)}/insights", query={"top": str(top)})
        return _parse(Insights, answer)

    def history(self, racer: str, board_id: str | None) -> list[HistoryItem]:
        """Every submission of the racer, following the pages."""
        pages = self._pages(RacerHistory, f"/racers/{_quote(racer)}/submissions", {"board": board_id})
        return [item for page in pages for item in page.history]

    def status(self, racer: str, board_id: str | None) -> RacerSummary:
        answer = self._call("GET", f"/racers/{_quote(racer)}", query={"board": board_id})
        return _parse(RacerSummary, answer)

    def laps_page(self, board_id: str, cursor: str | None) -> LapsPage:
        """One page of the board's laps: the CSV the board answers, read back into rows, and
        the next page's cursor from its ``Link`` header."""
        answer = self._call("GET", f"/boards/{_quote(board_id)}/laps.csv", query={"cursor": cursor},
                            text=True)
        reader = csv.DictReader(io.StringIO(answer.body), fieldnames=None if cursor is None
                                else LAP_COLUMNS)
        rows = [dict(row) for row in reader]
        return LapsPage(board_id, rows, _next_cursor((answer.headers or {}).get("Link", "")))

    def racer_card(self, board_id: str, racer: str, kind: Literal["png", "svg"]) -> bytes:
        """The racer's result card, as the board draws it."""
        path = f"/boards/{_quote(board_id)}/racers/{_quote(racer)}/card.{kind}"
        return bytes(self._call("GET", path, binary=True).body)

    def season_card(self, season_id: str, kind: Literal["png", "svg"]) -> bytes:
        """The season's podium card, as the board draws it."""
        return bytes(self._call("GET", f"/seasons/{_quote(season_id)}/card.{kind}", binary=True).body)

    # ---- organisers (always signed) -------------------------------------------------------

    def create_board(self, spec: BoardSpec) -> BoardView:
        return _parse(BoardView, self._call("POST", "/boards", body=spec, signed=True))

    def update_board(self, board_id: str, changes: BoardChanges) -> BoardView:
        # Only the fields the caller set: an absent field stays as it is, a null one is cleared.
        body = changes.model_dump_json(exclude_unset=True).encode("utf-8")
        answer = self._call("PATCH", f"/boards/{_quote(board_id)}", body=body, signed=True)
        return _parse(BoardView, answer)

    def close_board(self, board_id: str) -> BoardView:
        answer = self._call("POST", f"/boards/{_quote(board_id)}/close", signed=True)
        return _parse(BoardView, answer)

    def delete_board(self, board_id: str) -> BoardView:
        return _parse(BoardView, self._call("DELETE", f"/boards/{_quote(board_id)}", signed=True))

    def restore_board(self, board_id: str) -> BoardView:
        answer = self._call("POST", f"/boards/{_quote(board_id)}/restore", signed=True)
        return _parse(BoardView, answer)

    def rebuild_ranks(self, board_id: str, budget_s: float | None) -> RankCounters:
        # The board decides how long one request counts.
        answer = self._call("POST", f"/boards/{_quote(board_id)}/rank-counters", signed=True)
        return _parse(RankCounters, answer)

    def export_page(self, board_id: str, cursor: str | None) -> ExportPage:
        answer = self._call("GET", f"/boards/{_quote(board_id)}/export", query={"cursor": cursor},
                            signed=True)
        return _parse(ExportPage, answer)

    def export_lines(self, board_id: str) -> Iterator[tuple[ExportKind, bytes]]:
        cursor: str | None = None
        while True:
            page = self.export_page(board_id, cursor)
            for line in page.lines:
                yield line.kind, line.model_dump_json().encode() + b"\n"
            cursor = page.next_cursor
            if cursor is None:
                return

    def import_board(self, board: Board) -> tuple[BoardView, bool]:
        answer = self._call("PUT", f"/boards/{_quote(board.board_id)}/import", body=board,
                            signed=True)
        return _parse(BoardView, answer), answer.status == 201

    def import_submission(self, board_id: str, item: ImportedSubmission) -> ImportReceipt:
        answer = self._call("POST", f"/boards/{_quote(board_id)}/imports", body=item, signed=True)
        return _parse(ImportReceipt, answer)

    # ---- the signed-in caller, moderation and audit ---------------------------------------

    def join(self, code: str, renewing: str | None = None) -> Joined:
        """Join a `drboard serve` board with its join code (the answer holds a new token);
        ``renewing``, the token a racer holds already, keeps their sign-in (and alias)."""
        return _parse(Joined, self._call("POST", "/join", body=JoinRequest.model_construct(code=code),
                                         token=renewing))

    def me(self) -> Me:
        return _parse(Me, self._call("GET", "/me", signed=True))

    def claim_alias(self, alias: str) -> Me:
        return _parse(Me, self._call("PUT", "/me/alias", body=AliasRequest(alias=alias), signed=True))

    def remove_entry(self, board_id: str, racer: str) -> Moderation:
        path = f"/boards/{_quote(board_id)}/racers/{_quote(racer)}"
        return _parse(Moderation, self._call("DELETE", path, signed=True))

    def ban(self, board_id: str, racer: str, *, everywhere: bool = True) -> Moderation:
        path = f"/boards/{_quote(board_id)}/bans/{_quote(racer)}"
        query = {"scope": "event" if everywhere else "board"}
        return _parse(Moderation, self._call("PUT", path, query=query, signed=True))

    def unban(self, board_id: str, racer: str) -> Moderation:
        path = f"/boards/{_quote(board_id)}/bans/{_quote(racer)}"
        return _parse(Moderation, self._call("DELETE", path, signed=True))

    def audit(self, board_id: str, cursor: str | None, limit: int) -> AuditPage:
        answer = self._call("GET", f"/boards/{_quote(board_id)}/audit",
                            query={"cursor": cursor, "limit": str(limit)}, signed=True)
        return _parse(AuditPage, answer)

    # ---- seasons (reads public, changes signed) -------------------------------------------

    def seasons(self) -> list[SeasonSummary]:
        """Every season, following the pages."""
        return [season for page in self._pages(SeasonList, "/seasons", {}) for season in page.seasons]

    def season(self, season_id: str, limit: int, cursor: str | None) -> SeasonStandings:
        answer = self._call("GET", f"/seasons/{_quote(season_id)}",
                            query={"limit": str(limit), "cursor": cursor})
        return _parse(SeasonStandings, answer)

    def create_season(self, spec: SeasonSpec) -> SeasonStandings:
        return _parse(SeasonStandings, self._call("POST", "/seasons", body=spec, signed=True))

    def update_season(self, season_id: str, changes: SeasonChanges) -> SeasonStandings:
        body = changes.model_dump_json(exclude_unset=True).encode("utf-8")
        answer = self._call("PATCH", f"/seasons/{_quote(season_id)}", body=body, signed=True)
        return _parse(SeasonStandings, answer)

    def add_round(self, season_id: str, board_id: str, spec: RoundSpec) -> SeasonStandings:
        path = f"/seasons/{_quote(season_id)}/rounds/{_quote(board_id)}"
        return _parse(SeasonStandings, self._call("PUT", path, body=spec, signed=True))

    def remove_round(self, season_id: str, board_id: str) -> SeasonStandings:
        path = f"/seasons/{_quote(season_id)}/rounds/{_quote(board_id)}"
        return _parse(SeasonStandings, self._call("DELETE", path, signed=True))

    def set_final(self, season_id: str, spec: FinalSpec) -> SeasonStandings:
        path = f"/seasons/{_quote(season_id)}/final"
        return _parse(SeasonStandings, self._call("PUT", path, body=spec, signed=True))

    def clear_final(self, season_id: str) -> SeasonStandings:
        path = f"/seasons/{_quote(season_id)}/final"
        return _parse(SeasonStandings, self._call("DELETE", path, signed=True))

    def close_season(self, season_id: str) -> SeasonStandings:
        path = f"/seasons/{_quote(season_id)}/close"
        return _parse(SeasonStandings, self._call("POST", path, signed=True))

    def reopen_season(self, season_id: str) -> SeasonStandings:
        path = f"/seasons/{_quote(season_id)}/reopen"
        return _parse(SeasonStandings, self._call("POST", path, signed=True))

    def recheck_page(self, board_id: str, cursor: str | None) -> RecheckPage:
        answer = self._call("POST", f"/boards/{_quote(board_id)}/recheck", query={"cursor": cursor},
                            signed=True)
        return _parse(RecheckPage, answer)

    # ---- aliases (organisers) -------------------------------------------------------------

    def aliases(self, limit: int, cursor: str | None) -> AliasList:
        answer = self._call("GET", "/aliases", query={"limit": str(limit), "cursor": cursor},
                            signed=True)
        return _parse(AliasList, answer)

    def assign_alias(self, alias: str, principal: str | None, replace: bool) -> AliasView:
        answer = self._call("PUT", f"/aliases/{_quote(alias)}", body=AliasAssignment(principal=principal),
                            query={"replace": "true" if replace else None}, signed=True)
        return _parse(AliasView, answer)

    def release_alias(self, alias: str) -> AliasView:
        return _parse(AliasView, self._call("DELETE", f"/aliases/{_quote(alias)}", signed=True))

    def alias_audit(self, cursor: str | None, limit: int) -> AuditPage:
        answer = self._call("GET", "/aliases/audit", query={"cursor": cursor, "limit": str(limit)},
                            signed=True)
        return _parse(AuditPage, answer)

    # A board's webhooks, or a season's (``kind="season"``).

    def add_webhook(self, target_id: str, spec: WebhookSpec, *, kind: TargetKind = "board") -> WebhookView:
        answer = self._call("POST", _webhooks_path(kind, target_id), body=spec, signed=True)
        return _parse(WebhookView, answer)

    def webhooks(self, target_id: str, *, kind: TargetKind = "board") -> WebhookList:
        return _parse(WebhookList, self._call("GET", _webhooks_path(kind, target_id), signed=True))

    def remove_webhook(self, target_id: str, webhook_id: str, *, kind: TargetKind = "board") -> WebhookView:
        path = _webhooks_path(kind, target_id) + f"/{_quote(webhook_id)}"
        return _parse(WebhookView, self._call("DELETE", path, signed=True))

    def test_webhook(self, target_id: str, webhook_id: str, *, kind: TargetKind = "board") -> Delivery:
        path = _webhooks_path(kind, target_id) + f"/{_quote(webhook_id)}/test"
        return _parse(Delivery, self._call("POST", path, signed=True))

    # ---- HTTP ---------------------------------------------------------------------------

    def _pages(self, model: type[P], path: str, query: dict[str, str | None]) -> Iterator[P]:
        """Each page of a paginated read, at the largest page size, until ``next_cursor`` is
        null (or repeats: a board that answers the same cursor again is not followed round)."""
        cursor: str | None = None
        seen: set[str] = set()
        while True:
            page = _parse(model, self._call("GET", path, query=query | {
                "limit": str(MAX_PAGE), "cursor": cursor}))
            yield page
            cursor = page.next_cursor
            if cursor is None or cursor in seen:
                return
            seen.add(cursor)

    def _call(self, method: str, path: str, *, body: BaseModel | bytes | None = None,
              query: Mapping[str, str | list[str] | None] | None = None,
              signed: bool = False, token: str | None = None, text: bool = False,
              binary: bool = False) -> Answer:
        """One request; the answer's JSON (its UTF-8 text with ``text``, its bytes with
        ``binary``) and headers."""
        given = {name: value for name, value in (query or {}).items() if value}
        token = token or (fresh_token(self.endpoint) if signed else None)
        prefix = tokens.route_prefix(token) if token else ""
        url = self.endpoint + prefix + path + (
            f"?{urllib.parse.urlencode(given, doseq=True)}" if given else "")
        data = body.model_dump_json().encode("utf-8") if isinstance(body, BaseModel) else body
        headers = {"Accept": "application/json"}
        if data is not None:
            headers["Content-Type"] = "application/json"
        if token:
            headers["Authorization"] = f"Bearer {token}"
        elif signed:
            headers = _signed(method, url, data or b"", headers)
        request = urllib.request.Request(url, data=data, headers=headers, method=method)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout_s) as response:
                data = response.read()
                body = data if binary else data.decode("utf-8") if text else _json(data, url)
                return Answer(response.status, body, response.headers)
        except urllib.error.HTTPError as error:
            raise _domain_error(error, url) from None
        except (urllib.error.URLError, TimeoutError, ConnectionError) as error:
            reason = getattr(error, "reason", error)
            raise errors.BoardUnreachable(f"cannot reach {self.endpoint}: {reason}") from None


def _quote(part: str) -> str:
    return urllib.parse.quote(part, safe="")


def _webhooks_path(kind: TargetKind, target_id: str) -> str:
    return f"/{'seasons' if kind == 'season' else 'boards'}/{_quote(target_id)}/webhooks"


_NEXT_LINK = re.compile(r'<([^>]*)>\s*;\s*rel="?next"?')


def _next_cursor(link: str) -> str | None:
    """The ``cursor`` of the page a ``Link: <...>; rel="next"`` header names, if any."""
    found = _NEXT_LINK.search(link)
    if not found:
        return None
    cursors = urllib.parse.parse_qs(urllib.parse.urlsplit(found.group(1)).query).get("cursor")
    return cursors[0] if cursors else None


def _json(data: bytes, url: str) -> Any:
    try:
        return json.loads(data)
    except ValueError:
        raise errors.BoardUnreachable(f"{url} did not answer with JSON") from None


def _parse(model: type[T], answer: Answer) -> T:
    try:
        return model.model_validate(answer.body)
    except ValidationError as error:
        raise errors.BoardUnreachable(f"unexpected answer from the board: {error}") from None


def _signed(method: str, url: str, body: bytes, headers: dict[str, str]) -> dict[str, str]:
    """SigV4-sign for API Gateway when AWS credentials are configured; unsigned otherwise."""
    import botocore.session
    from botocore.auth import SigV4Auth
    from botocore.awsrequest import AWSRequest

    session = botocore.session.get_session()
    credentials = session.get_credentials()
    if credentials is None:
        return headers
    match = _API_REGION.search(urllib.parse.urlsplit(url).netloc)
    region = (match.group(1) if match else None) or session.get_config_variable("region")
    request = AWSRequest(method=method, url=url, data=body, headers=headers)
    SigV4Auth(credentials.get_frozen_credentials(), "execute-api", region or "us-east-1").add_auth(
        request)
    return dict(request.headers.items())


#: The domain errors a board may name in an error answer's ``error`` field.
_NAMED_ERRORS: dict[str, type[errors.DomainError]] = {
    kind.__name__: kind for kind in vars(errors).values()
    if isinstance(kind, type) and issubclass(kind, errors.DomainError)
    and kind not in (errors.DomainError, errors.BoardUnreachable)
}

#: Answers without a domain error's name (API Gateway's own, a proxy's): their status decides.
_STATUS_ERRORS: dict[int, type[errors.DomainError]] = {
    400: errors.InvalidQuery,
    401: errors.NotAuthorized,
    403: errors.NotAuthorized,
    404: errors.BoardNotFound,
    413: errors.SubmissionTooLarge,
    422: errors.InvalidSubmission,
}

_SIGN_HINT = ("a deployed board takes pushes and organiser requests signed with AWS credentials "
              "allowed to invoke its API")


def _domain_error(error: urllib.error.HTTPError, url: str) -> errors.DomainError:
    try:
        answer = json.loads(error.read() or b"{}")
    except ValueError:
        answer = {}
    if not isinstance(answer, dict):
        answer = {}
    message = _message(answer) or f"{url} answered {error.code} {error.reason}"
    detail = _detail(answer.get("detail"))
    if detail:
        message = f"{message}: {detail[0]['loc']}: {detail[0]['msg']}"
    named = _NAMED_ERRORS.get(str(answer.get("error", "")))
    retry_text = (error.headers.get("Retry-After") or "").strip()
    retry = int(retry_text) if retry_text.isdigit() else None
    if named is errors.TooSoon or (named is None and error.code == 429):
        return errors.TooSoon(message, retry if retry is not None else DEFAULT_RETRY_AFTER_S)
    if named is not None and issubclass(named, errors.StoreError):
        return named(message, retry if retry is not None else 1)
    if named is None and error.code == 503:
        return errors.StoreUnavailable(message, retry if retry is not None else 1)
    if named is not None:
        return named(message, detail=detail)
    if error.code in (401, 403):
        return errors.NotAuthorized(f"{message} ({_SIGN_HINT})")
    return _STATUS_ERRORS.get(error.code, errors.BoardUnreachable)(message)


def _detail(value: Any) -> list[dict[str, str]]:
    if not isinstance(value, list):
        return []
    return [{"loc": str(item.get("loc", "")), "msg": str(item.get("msg", "")),
             "type": str(item.get("type", "value_error"))}
            for item in value if isinstance(item, dict)]


def _message(answer: Any) -> str | None:
    if isinstance(answer, dict):
        for key in ("message", "Message"):
            if isinstance(answer.get(key), str):
                return str(answer[key])
    return None
