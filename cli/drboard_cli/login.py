"""Signing in to a deployed board's Cognito user pool: `drboard login`, and keeping the token fresh.

The board says how to sign in at ``/.well-known/drboard.json`` (its user pool, public app client,
hosted sign-in domain and scopes). Two ways in:

- in a browser, with the OAuth 2 authorization code flow and PKCE (S256) on a loopback redirect
  (``http://localhost:8765/callback``, the one the app client allows), through Authlib. On a
  machine with no browser (a headless training machine) the address is printed instead, the
  racer signs in on any other device, and pastes back the address the browser was sent to
  (which does not load there, but holds the code) or the code alone;
- with a user name and password, for machines with no browser, through pycognito's SRP (the
  password never leaves the machine); an invited racer's temporary password is replaced there.

The tokens are saved per board (:mod:`drboard_cli.tokens`); an access token about to expire is
renewed with the refresh token before it is sent.
"""

from __future__ import annotations

import base64
import contextlib
import json
import secrets
import urllib.error
import urllib.request
from collections.abc import Callable
from datetime import UTC, datetime, timedelta
from http.server import BaseHTTPRequestHandler, HTTPServer
from typing import Any
from urllib.parse import parse_qs, urlencode, urlsplit

from drboard_functions.errors import BoardUnreachable, NotAuthorized, NotSignedIn
from drboard_functions.identity import SignIn
from pydantic import ValidationError

from . import tokens

CALLBACK_PORT = 8765
CALLBACK_PATH = "/callback"
REDIRECT_URI = f"http://localhost:{CALLBACK_PORT}{CALLBACK_PATH}"
BROWSER_WAIT_S = 300
TIMEOUT_S = 20


def sign_in_settings(endpoint: str) -> SignIn:
    """How the board at ``endpoint`` takes sign-ins."""
    url = endpoint.rstrip("/") + "/.well-known/drboard.json"
    try:
        with urllib.request.urlopen(url, timeout=TIMEOUT_S) as response:
            return SignIn.model_validate_json(response.read())
    except (urllib.error.URLError, TimeoutError, ConnectionError) as error:
        raise BoardUnreachable(f"cannot reach {url}: {getattr(error, 'reason', error)}") from None
    except ValidationError:
        raise BoardUnreachable(f"{url} did not say how to sign in") from None


def require_cognito(settings: SignIn, endpoint: str) -> SignIn:
    """The settings, when the board takes Cognito sign-ins; else why not."""
    if settings.kind == "join-code":
        raise NotAuthorized(f"{endpoint} is a `drboard serve` board: join it with the code its "
                            "organiser shows, `drboard join CODE`")
    if settings.kind != "cognito" or not (settings.client_id and settings.user_pool_id):
        raise NotAuthorized(f"{endpoint} takes no sign-ins")
    return settings


# ---- the password, through SRP --------------------------------------------------------------


def login_with_password(endpoint: str, settings: SignIn, username: str, password: str,
                        new_password: Callable[[], str], client: Any = None) -> tokens.SavedToken:
    """Sign in with SRP; ``new_password`` is asked for when the password is a temporary one."""
    from pycognito.aws_srp import AWSSRP
    from pycognito.exceptions import ForceChangePasswordException

    settings = require_cognito(settings, endpoint)
    cognito = client or _cognito_client(settings)
    srp = AWSSRP(username=username, password=password, pool_id=settings.user_pool_id,
                 client_id=settings.client_id, client=cognito)
    try:
        try:
            answer = srp.authenticate_user()
        except ForceChangePasswordException:
            answer = srp.set_new_password_challenge(new_password())
    except cognito.exceptions.NotAuthorizedException:
        raise NotAuthorized("the user name or password is wrong") from None
    except cognito.exceptions.UserNotFoundException:
        raise NotAuthorized("the user name or password is wrong") from None
    return _saved(endpoint, settings, answer["AuthenticationResult"])


def _cognito_client(settings: SignIn) -> Any:
    import boto3
    from botocore import UNSIGNED
    from botocore.config import Config

    # Signing in needs no AWS credentials: the calls are unsigned.
    return boto3.client("cognito-idp", region_name=settings.region,
                        config=Config(signature_version=UNSIGNED))


# ---- the browser, through the authorization code flow with PKCE -------------------------------


class _Callback(BaseHTTPRequestHandler):
    """Takes the one redirect back from the sign-in page."""

    server: _CallbackServer

    def do_GET(self) -> None:
        parts = urlsplit(self.path)
        if parts.path != CALLBACK_PATH:
            self.send_error(404)
            return
        self.server.received = f"{REDIRECT_URI}?{parts.query}"
        query = parse_qs(parts.query)
        said = ("Signed in to drboard: you can close this tab." if "code" in query
                else "drboard sign-in failed: see the terminal.")
        body = f"<!doctype html><title>drboard</title><p>{said}</p>".encode()
        self.send_response(200)
        self.send_header("Content-Type", "text/html; charset=utf-8")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format: str, *args: Any) -> None:
        pass


class _CallbackServer(HTTPServer):
    received: str | None = None


class _HostedSignIn:
    """One sign-in on the board's hosted page (authorization code with PKCE): its address, and
    the exchange of the code the page sends back for the racer's token."""

    def __init__(self, endpoint: str, settings: SignIn) -> None:
        from authlib.integrations.requests_client import OAuth2Session

        settings = require_cognito(settings, endpoint)
        if not settings.domain:
            raise NotAuthorized(f"{endpoint} has no sign-in page: use `drboard login --password`")
        self.endpoint, self.settings = endpoint, settings
        self.session = OAuth2Session(settings.client_id, scope=" ".join(settings.scopes or ["openid"]),
                                     redirect_uri=REDIRECT_URI, code_challenge_method="S256")
        self.verifier = secrets.token_urlsafe(64)
        self.url, self.state = self.session.create_authorization_url(
            f"{settings.domain}/oauth2/authorize", code_verifier=self.verifier)

    def finish(self, received: str) -> tokens.SavedToken:
        """The token the page's answer (the address it sent the browser back to) is worth."""
        answer = self.session.fetch_token(f"{self.settings.domain}/oauth2/token",
                                          authorization_response=received,
                                          code_verifier=self.verifier, state=self.state)
        return _saved(self.endpoint, self.settings, {"AccessToken": answer["access_token"],
                                                     "RefreshToken": answer.get("refresh_token"),
                                                     "ExpiresIn": answer.get("expires_in", 3600)})


def login_in_browser(endpoint: str, settings: SignIn, show: Callable[[str], None],
                     open_browser: bool = True, wait_s: float = BROWSER_WAIT_S) -> tokens.SavedToken:
    """Open the hosted sign-in page (or print its address) and wait for its redirect."""
    sign_in = _HostedSignIn(endpoint, settings)
    server = _CallbackServer(("127.0.0.1", CALLBACK_PORT), _Callback)
    server.timeout = 1
    try:
        show(sign_in.url)
        if open_browser:
            import webbrowser

            webbrowser.open(sign_in.url)
        received = _wait_for_redirect(server, wait_s)
    finally:
        server.server_close()
    query = parse_qs(urlsplit(received).query)
    if query.get("state", [""])[0] != sign_in.state:
        raise NotAuthorized("the sign-in page answered another sign-in (state differs): try again")
    if "error" in query:
        raise NotAuthorized(f"sign-in refused: {query.get('error_description', query['error'])[0]}")
    return sign_in.finish(received)


def login_with_pasted_code(endpoint: str, settings: SignIn, show: Callable[[str], None],
                           ask: Callable[[], str]) -> tokens.SavedToken:
    """Sign in from a machine with no browser: ``show`` the sign-in address, then ``ask`` for
    what the browser shows after signing in: the address it was sent back to
    (``http://localhost:8765/callback?code=…&state=…``, which fails to load on another device,
    but its address bar holds the code), or the code alone. PKCE binds the code to this
    machine's verifier, so a code pasted alone is as safe as the redirect."""
    sign_in = _HostedSignIn(endpoint, settings)
    show(sign_in.url)
    return sign_in.finish(pasted_redirect(ask(), sign_in.state))


def pasted_redirect(pasted: str, state: str) -> str:
    """The redirect address to finish signing in with, from what the racer pasted: the whole
    address (its state must be this sign-in's) or the code alone."""
    text = pasted.strip().strip("'\"<>")
    if not text:
        raise NotSignedIn("nothing was pasted: run `drboard login --no-browser` again")
    if "code=" in text or "error=" in text:
        query = parse_qs(urlsplit(text).query or text.split("?", 1)[-1])
        if "error" in query:
            raise NotAuthorized(f"sign-in refused: {query.get('error_description', query['error'])[0]}")
        if query.get("state", [state])[0] != state:
            raise NotAuthorized("that address is from another sign-in (its state differs): paste "
                                "the one this sign-in's page sent you to")
        code = query.get("code", [""])[0]
    else:
        code = text
    if not code or any(ch.isspace() for ch in code) or len(code) > 2048:
        raise NotSignedIn("that is neither the address the sign-in page sent you to nor its code")
    return f"{REDIRECT_URI}?{urlencode({'code': code, 'state': state})}"


def _wait_for_redirect(server: _CallbackServer, wait_s: float) -> str:
    stop = datetime.now(UTC) + timedelta(seconds=wait_s)
    while server.received is None:
        if datetime.now(UTC) > stop:
            raise NotSignedIn(f"no sign-in within {wait_s:.0f} s: run `drboard login` again")
        server.handle_request()
    return server.received


# ---- the saved token, and keeping it fresh ----------------------------------------------------


def _saved(endpoint: str, settings: SignIn, result: dict[str, Any]) -> tokens.SavedToken:
    claims = token_claims(result["AccessToken"])
    token = tokens.SavedToken(
        kind="cognito", access_token=result["AccessToken"],
        refresh_token=result.get("RefreshToken"),
        expires_at=datetime.now(UTC) + timedelta(seconds=int(result.get("ExpiresIn") or 3600)),
        client_id=settings.client_id, region=settings.region, domain=settings.domain,
        username=str(claims.get("username") or claims.get("cognito:username") or ""),
    )
    tokens.save(endpoint, token)
    return token


def token_claims(token: str) -> dict[str, Any]:
    """The claims a JWT carries, unverified: only to show who is signed in (the board checks)."""
    try:
        payload = token.split(".")[1]
        claims = json.loads(base64.urlsafe_b64decode(payload + "=" * (-len(payload) % 4)))
    except (IndexError, ValueError):
        return {}
    return claims if isinstance(claims, dict) else {}


def fresh_token(endpoint: str, client: Any = None) -> str | None:
    """The access token to send to ``endpoint``: ``DRBOARD_TOKEN``, else the saved one, renewed
    with its refresh token when it is about to expire."""
    given = tokens.from_environment()
    if given:
        return given
    saved = tokens.load(endpoint)
    if saved is None:
        return None
    if saved.kind == "cognito" and saved.expired() and saved.refresh_token:
        saved = _refreshed(endpoint, saved, client)
    return saved.access_token


def _refreshed(endpoint: str, saved: tokens.SavedToken, client: Any = None) -> tokens.SavedToken:
    settings = SignIn(kind="cognito", region=saved.region, client_id=saved.client_id)
    cognito = client or _cognito_client(settings)
    try:
        answer = cognito.initiate_auth(ClientId=saved.client_id, AuthFlow="REFRESH_TOKEN_AUTH",
                                       AuthParameters={"REFRESH_TOKEN": saved.refresh_token})
    except cognito.exceptions.NotAuthorizedException:
        tokens.forget(endpoint)
        raise NotSignedIn("your sign-in has run out: run `drboard login` again") from None
    result = answer["AuthenticationResult"]
    renewed = saved.model_copy(update={
        "access_token": result["AccessToken"],
        "expires_at": datetime.now(UTC) + timedelta(seconds=int(result.get("ExpiresIn") or 3600)),
    })
    tokens.save(endpoint, renewed)
    return renewed


def logout(endpoint: str, client: Any = None) -> bool:
    """Forget the board's token, revoking its refresh token first where the board can."""
    saved = tokens.load(endpoint)
    if saved is not None and saved.kind == "cognito" and saved.refresh_token and saved.client_id:
        settings = SignIn(kind="cognito", region=saved.region, client_id=saved.client_id)
        from botocore.exceptions import BotoCoreError, ClientError

        with contextlib.suppress(BotoCoreError, ClientError):  # forgotten here whatever the pool says
            (client or _cognito_client(settings)).revoke_token(Token=saved.refresh_token,
                                                               ClientId=saved.client_id)
    return tokens.forget(endpoint)
