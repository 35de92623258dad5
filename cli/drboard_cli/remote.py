"""A deployed board (or `drboard serve`) over HTTP: the same calls as the in-process board.

Pushes are signed with SigV4 using the caller's AWS credentials when there are any, since a
deployed board only takes IAM-authorised writes; reads are public.
"""

from __future__ import annotations

import json
import re
import urllib.error
import urllib.parse
import urllib.request
from typing import Any, TypeVar

from drboard_assembler.record import Record
from drboard_functions import errors
from drboard_functions.models import BoardPage, BoardView, HistoryItem, PushReceipt, RacerView
from drboard_functions.service import default_board_id
from pydantic import BaseModel, TypeAdapter, ValidationError

T = TypeVar("T", bound=BaseModel)

TIMEOUT_S = 20
_API_REGION = re.compile(r"\.execute-api\.([a-z0-9-]+)\.")


class HttpBoard:
    def __init__(self, endpoint: str, timeout_s: float = TIMEOUT_S) -> None:
        self.endpoint = endpoint.rstrip("/")
        self.timeout_s = timeout_s

    # ---- the BoardClient calls ------------------------------------------------------------

    def push(self, record: Record, board_id: str | None) -> PushReceipt:
        board = board_id or default_board_id(record.track, record.direction, record.race_type)
        body = record.model_dump_json().encode("utf-8")
        answer = self._call("POST", f"/boards/{_quote(board)}/submissions", body=body)
        return _parse(PushReceipt, answer)

    def boards(self) -> list[BoardView]:
        answer = self._call("GET", "/boards")
        items = answer.get("boards", answer) if isinstance(answer, dict) else answer
        try:
            return TypeAdapter(list[BoardView]).validate_python(items)
        except ValidationError as error:
            raise errors.BoardUnreachable(f"unexpected answer from {self.endpoint}: {error}") from None

    def board_page(self, board_id: str, limit: int, cursor: str | None) -> BoardPage:
        query = {"limit": str(limit)} | ({"cursor": cursor} if cursor else {})
        answer = self._call("GET", f"/boards/{_quote(board_id)}?{urllib.parse.urlencode(query)}")
        return _parse(BoardPage, answer)

    def racer(self, board_id: str, racer: str) -> RacerView:
        answer = self._call("GET", f"/boards/{_quote(board_id)}/racers/{_quote(racer)}")
        return _parse(RacerView, answer)

    def history(self, racer: str, board_id: str | None) -> list[HistoryItem]:
        board_ids = [board_id] if board_id else [b.board_id for b in self.boards()]
        items: list[HistoryItem] = []
        for board in board_ids:
            try:
                items.extend(self.racer(board, racer).history)
            except (errors.RacerNotFound, errors.BoardNotFound):
                if board_id:
                    raise
        return sorted(items, key=lambda item: item.submitted_at)

    # ---- HTTP ---------------------------------------------------------------------------

    def _call(self, method: str, path: str, body: bytes | None = None) -> Any:
        url = self.endpoint + path
        headers = {"Accept": "application/json"}
        if body is not None:
            headers["Content-Type"] = "application/json"
            headers = _signed(method, url, body, headers)
        request = urllib.request.Request(url, data=body, headers=headers, method=method)
        try:
            with urllib.request.urlopen(request, timeout=self.timeout_s) as response:
                return _json(response.read(), url)
        except urllib.error.HTTPError as error:
            raise _domain_error(error, url) from None
        except (urllib.error.URLError, TimeoutError, ConnectionError) as error:
            reason = getattr(error, "reason", error)
            raise errors.BoardUnreachable(f"cannot reach {self.endpoint}: {reason}") from None


def _quote(part: str) -> str:
    return urllib.parse.quote(part, safe="")


def _json(data: bytes, url: str) -> Any:
    try:
        return json.loads(data)
    except ValueError:
        raise errors.BoardUnreachable(f"{url} did not answer with JSON") from None


def _parse(model: type[T], answer: Any) -> T:
    try:
        return model.model_validate(answer)
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


_STATUS_ERRORS: dict[int, type[errors.DomainError]] = {
    400: errors.InvalidQuery,
    401: errors.NotAuthorized,
    403: errors.NotAuthorized,
    404: errors.BoardNotFound,
    413: errors.SubmissionTooLarge,
    422: errors.InvalidSubmission,
}


def _domain_error(error: urllib.error.HTTPError, url: str) -> errors.DomainError:
    try:
        answer = json.loads(error.read() or b"{}")
    except ValueError:
        answer = {}
    if not isinstance(answer, dict):
        answer = {}
    message = _message(answer) or f"{url} answered {error.code} {error.reason}"
    detail = answer.get("detail")
    if isinstance(detail, list) and detail and isinstance(detail[0], dict) and "loc" in detail[0]:
        message = f"{message}: {detail[0].get('loc')}: {detail[0].get('msg', '')}"
    if error.code == 429:
        retry = error.headers.get("Retry-After", "60")
        return errors.TooSoon(message, int(retry) if retry.isdigit() else 60)
    if error.code in (401, 403):
        return errors.NotAuthorized(
            f"{message} (a deployed board takes pushes signed with AWS credentials allowed to "
            "invoke its API)")
    # The board names the domain error it raised; otherwise the status decides.
    named = getattr(errors, str(answer.get("error", "")), None)
    if isinstance(named, type) and issubclass(named, errors.DomainError) and named is not errors.TooSoon:
        return named(message)
    return _STATUS_ERRORS.get(error.code, errors.BoardUnreachable)(message)


def _message(answer: Any) -> str | None:
    if isinstance(answer, dict):
        for key in ("message", "Message"):
            if isinstance(answer.get(key), str):
                return str(answer[key])
    return None
