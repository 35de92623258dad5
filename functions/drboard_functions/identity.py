"""Who is calling. The edges say (a Lambda handler from API Gateway's authorizer context,
`drboard serve` from its own sign-in, the in-process CLI as the organiser at the keyboard);
the service decides what the caller may do.

The authorizer context a request carries is one of:
- ``requestContext.authorizer.jwt.claims``: a Cognito access token checked by the HTTP API's JWT
  authorizer (a racer, or an organiser when ``cognito:groups`` holds ``organisers``);
- ``requestContext.authorizer.iam``: a SigV4-signed request (an organiser's own scripts);
- ``requestContext.authorizer.lambda``: what `drboard serve` sets itself for the computer it
  runs on and for racers who joined with a code. API Gateway never forwards a client's own
  ``requestContext``, and `serve` builds every event itself, so no client can claim one.
"""

from __future__ import annotations

from typing import Any, Literal, NamedTuple

from pydantic import BaseModel, ConfigDict

ORGANISERS_GROUP = "organisers"


class Caller(NamedTuple):
    """A signed-in caller. ``principal`` is stable and unique (``cognito:<sub>``,
    ``iam:<arn>``, ``join:<id>``, ``local``); ``name`` is for people (audit, whoami). Made here
    and by the edges from what they checked themselves, never read from a client's JSON: a
    value, not a schema."""

    principal: str
    name: str = ""
    organiser: bool = False


#: The person at the computer that holds the embedded board (or runs `drboard serve`).
LOCAL_ORGANISER = Caller(principal="local", name="this computer", organiser=True)


def caller_from_event(event: dict[str, Any]) -> Caller | None:
    """The caller an API Gateway HTTP API (v2) event was authorised as, or None (anonymous)."""
    authorizer = (event.get("requestContext") or {}).get("authorizer") or {}
    claims = (authorizer.get("jwt") or {}).get("claims")
    if claims:
        return _from_jwt_claims(claims)
    iam = authorizer.get("iam")
    if iam:
        arn = str(iam.get("userArn") or iam.get("userId") or "")
        return Caller(principal=f"iam:{arn}", name=arn, organiser=True) if arn else None
    local = authorizer.get("lambda")
    if local and local.get("principal"):
        return Caller(principal=str(local["principal"]), name=str(local.get("name") or ""),
                      organiser=bool(local.get("organiser")))
    return None


def _from_jwt_claims(claims: dict[str, Any]) -> Caller | None:
    if claims.get("token_use") != "access" or not claims.get("sub"):
        return None  # an ID token, or no subject: not a sign-in this board accepts
    return Caller(principal=f"cognito:{claims['sub']}", name=str(claims.get("username") or ""),
                  organiser=ORGANISERS_GROUP in cognito_groups(claims.get("cognito:groups")))


def cognito_groups(claim: Any) -> list[str]:
    """The groups of a ``cognito:groups`` claim: a JSON list as Cognito writes it, or the string
    API Gateway's JWT authorizer makes of a list claim, ``"[organisers other]"`` (its items
    apart by spaces; a group's name may hold a comma, never a space)."""
    if isinstance(claim, list):
        return [str(group) for group in claim]
    if not isinstance(claim, str):
        return []
    text = claim.strip()
    if text.startswith("[") and text.endswith("]"):
        text = text[1:-1]
    return text.split()


class SignIn(BaseModel):
    """How racers sign in to this board: what ``GET /.well-known/drboard.json`` tells
    `drboard login --endpoint URL`. The edges put one in the resolver's context
    (``app.append_context(sign_in=...)``): the functions from the stack's settings,
    `drboard serve` from its own options."""

    model_config = ConfigDict(defer_build=True)

    kind: Literal["cognito", "join-code", "none"] = "none"
    region: str | None = None
    user_pool_id: str | None = None
    client_id: str | None = None
    domain: str | None = None  # the user pool's hosted sign-in domain, e.g. https://x.auth.eu-west-1.amazoncognito.com
    scopes: list[str] = []
