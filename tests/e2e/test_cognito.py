"""Racers and organisers sign in to a deployed board's Cognito user pool (moto's cognito-idp),
and the board behind an API Gateway stand-in takes their pushes and organiser requests only as
the sign-in allows.

The stand-in does what the HTTP API's JWT authorizer does before a function runs: requests under
``/cognito`` need a bearer token issued by the pool for the CLI's app client, whose claims it
hands the functions as ``requestContext.authorizer.jwt.claims``.
"""

from __future__ import annotations

import base64
import hashlib
import json
import os
import threading
import urllib.request
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

import boto3
import pytest
from click.testing import CliRunner, Result
from drboard_cli import login as signing_in
from drboard_cli import tokens
from drboard_cli.main import cli
from drboard_cli.serve import LocalContext, http_event
from drboard_functions import errors
from drboard_functions.identity import SignIn
from drboard_functions.routes import admin_router, build_app, canonical_event, pull_router, push_router
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore
from moto import mock_aws

REGION = "eu-west-1"
EXAMPLES = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())
TEMPORARY = "Temporary-Pass-1"
CHOSEN = "My-Own-Pass-2"


def claims_of(token: str) -> dict[str, Any]:
    return signing_in.token_claims(token)


class Gateway(ThreadingHTTPServer):
    """The HTTP API in front of the functions: the JWT authorizer on /cognito, the resolver."""

    daemon_threads = True

    def __init__(self, issuer: str, client_id: str, sign_in: SignIn) -> None:
        super().__init__(("127.0.0.1", 0), _GatewayHandler)
        self.issuer = issuer
        self.client_id = client_id
        self.store = SqliteStore(":memory:")
        self.service = LeaderboardService(self.store)
        self.app = build_app(push_router, pull_router, admin_router)
        self.sign_in = sign_in
        self.lock = threading.Lock()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server_address[1]}"

    def answer(self, event: dict[str, Any]) -> dict[str, Any]:
        if event["rawPath"].startswith("/cognito/"):
            scheme, _, token = event["headers"].get("authorization", "").partition(" ")
            claims = claims_of(token) if scheme.lower() == "bearer" else {}
            if claims.get("iss") != self.issuer or claims.get("client_id") != self.client_id:
                return {"statusCode": 401, "body": json.dumps({"message": "Unauthorized"})}
            event["requestContext"]["authorizer"] = {"jwt": {"claims": claims, "scopes": None}}
        with self.lock:
            self.app.append_context(service=self.service, sign_in=self.sign_in)
            return self.app.resolve(canonical_event(event), LocalContext())  # type: ignore[arg-type]


class _GatewayHandler(BaseHTTPRequestHandler):
    server: Gateway
    protocol_version = "HTTP/1.1"

    def _any(self) -> None:
        body = self.rfile.read(int(self.headers.get("Content-Length") or 0))
        event = http_event(self.command, self.path, dict(self.headers.items()), body, "198.51.100.7")
        result = self.server.answer(event)
        data = (result.get("body") or "").encode()
        self.send_response(int(result["statusCode"]))
        for name, value in (result.get("headers") or {}).items():
            if name.lower() not in ("content-length", "connection"):
                self.send_header(name, str(value))
        self.send_header("Content-Length", str(len(data)))
        self.end_headers()
        self.wfile.write(data)

    do_GET = do_POST = do_PUT = do_PATCH = do_DELETE = _any

    def log_message(self, format: str, *args: Any) -> None:
        pass


class Pool:
    def __init__(self) -> None:
        self.client = boto3.client("cognito-idp", region_name=REGION)
        self.id = self.client.create_user_pool(
            PoolName="racers", AdminCreateUserConfig={"AllowAdminCreateUserOnly": True},
        )["UserPool"]["Id"]
        self.client_id = self.client.create_user_pool_client(
            UserPoolId=self.id, ClientName="drboard-cli", GenerateSecret=False,
            ExplicitAuthFlows=["ALLOW_USER_SRP_AUTH", "ALLOW_REFRESH_TOKEN_AUTH"],
        )["UserPoolClient"]["ClientId"]
        self.client.create_group(UserPoolId=self.id, GroupName="organisers")

    def invite(self, username: str, organiser: bool = False) -> None:
        self.client.admin_create_user(UserPoolId=self.id, Username=username,
                                      TemporaryPassword=TEMPORARY)
        if organiser:
            self.client.admin_add_user_to_group(UserPoolId=self.id, Username=username,
                                                GroupName="organisers")

    @property
    def issuer(self) -> str:
        return f"https://cognito-idp.{REGION}.amazonaws.com/{self.id}"


@pytest.fixture
def pool(monkeypatch: pytest.MonkeyPatch) -> Iterator[Pool]:
    for name, value in {"AWS_ACCESS_KEY_ID": "testing", "AWS_SECRET_ACCESS_KEY": "testing",
                        "AWS_DEFAULT_REGION": REGION}.items():
        monkeypatch.setenv(name, value)
    monkeypatch.delenv("AWS_PROFILE", raising=False)
    with mock_aws():
        yield Pool()


@pytest.fixture
def gateway(pool: Pool) -> Iterator[Gateway]:
    sign_in = SignIn(kind="cognito", region=REGION, user_pool_id=pool.id, client_id=pool.client_id,
                     domain="https://drboard-test.auth.eu-west-1.amazoncognito.com",
                     scopes=["openid", "email", "profile"])
    server = Gateway(pool.issuer, pool.client_id, sign_in)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server
    server.shutdown()
    server.server_close()
    server.store.close()


def drboard(gateway: Gateway, *args: str, stdin: str | None = None) -> Result:
    return CliRunner().invoke(cli, ["--endpoint", gateway.url, *args], input=stdin)


def sign_in(gateway: Gateway, username: str) -> Result:
    answers = f"{TEMPORARY}\n{CHOSEN}\n{CHOSEN}\n"
    return drboard(gateway, "login", "--password", "--username", username, stdin=answers)


def test_an_invited_racer_signs_in_with_a_password_and_chooses_their_own(
        gateway: Gateway, pool: Pool) -> None:
    pool.invite("ada")
    result = sign_in(gateway, "ada")
    assert result.exit_code == 0, result.output
    assert f"Signed in to {gateway.url} as ada" in result.stdout
    saved = tokens.load(gateway.url)
    assert saved is not None and saved.kind == "cognito" and saved.refresh_token
    assert claims_of(saved.access_token)["token_use"] == "access"
    assert oct(os.stat(tokens.tokens_path()).st_mode & 0o777) == "0o600"
    again = drboard(gateway, "login", "--password", "--username", "ada", stdin=f"{CHOSEN}\n")
    assert again.exit_code == 0, "the chosen password is the racer's from now on"


def test_a_signed_in_racer_pushes_only_as_themselves(gateway: Gateway, pool: Pool) -> None:
    pool.invite("ada")
    sign_in(gateway, "ada")
    assert "no alias yet" in drboard(gateway, "whoami").stdout
    pushed = drboard(gateway, "push", str(EXAMPLES[0]), "--racer", "Ada")
    assert pushed.exit_code == 0, pushed.output
    assert "you push as Ada" in drboard(gateway, "whoami").stdout
    other = drboard(gateway, "push", str(EXAMPLES[1]), "--racer", "Bob")
    assert other.exit_code == 1 and "you push as 'Ada'" in other.stderr
    pool.invite("mallory")
    sign_in(gateway, "mallory")
    stolen = drboard(gateway, "push", str(EXAMPLES[1]), "--racer", "ada")
    assert stolen.exit_code == 1 and "belongs to another racer" in stolen.stderr
    assert [b.participants for b in gateway.service.boards()] == [1]


def test_only_the_organisers_group_manages_boards(gateway: Gateway, pool: Pool) -> None:
    pool.invite("ada")
    pool.invite("org", organiser=True)
    create = ["board", "create", "club-night", "--title", "Club night", "--track", "reInvent2019"]
    sign_in(gateway, "ada")
    refused = drboard(gateway, *create)
    assert refused.exit_code == 1 and "only the board's organisers" in refused.stderr
    sign_in(gateway, "org")
    assert drboard(gateway, *create).exit_code == 0
    assert "an organiser" in drboard(gateway, "whoami").stdout
    trail = json.loads(drboard(gateway, "audit", "club-night", "--format", "json").stdout)
    [created] = trail
    assert created["action"] == "create" and created["actor"].startswith("cognito:")


def test_a_token_about_to_expire_is_renewed_before_it_is_sent(gateway: Gateway, pool: Pool) -> None:
    pool.invite("ada")
    sign_in(gateway, "ada")
    saved = tokens.load(gateway.url)
    assert saved is not None
    tokens.save(gateway.url, saved.model_copy(update={"expires_at": datetime.now(UTC)}))
    assert drboard(gateway, "whoami").exit_code == 0
    renewed = tokens.load(gateway.url)
    assert renewed is not None and renewed.expires_at is not None
    assert renewed.expires_at > datetime.now(UTC) + timedelta(minutes=30)
    assert renewed.refresh_token == saved.refresh_token


def test_after_logout_a_push_is_refused(gateway: Gateway, pool: Pool,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    pool.invite("ada")
    sign_in(gateway, "ada")
    revoked: list[str] = []

    class Revoking:  # moto has no RevokeToken: record what the pool would be asked
        def revoke_token(self, Token: str, ClientId: str) -> None:
            revoked.append(Token)

    monkeypatch.setattr(signing_in, "_cognito_client", lambda settings: Revoking())
    saved = tokens.load(gateway.url)
    assert f"Signed out of {gateway.url}" in drboard(gateway, "logout").stdout
    assert saved is not None and revoked == [saved.refresh_token]
    assert tokens.load(gateway.url) is None
    refused = drboard(gateway, "push", str(EXAMPLES[0]), "--racer", "Ada")
    assert refused.exit_code == 1 and "sign in to push" in refused.stderr
    assert "not signed in" in drboard(gateway, "logout").stdout


def test_drboard_token_signs_ci_jobs_in(gateway: Gateway, pool: Pool,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    pool.invite("ci-bot")
    sign_in(gateway, "ci-bot")
    saved = tokens.load(gateway.url)
    assert saved is not None
    tokens.forget(gateway.url)
    monkeypatch.setenv("DRBOARD_TOKEN", saved.access_token)
    assert "Signed in as ci-bot" in drboard(gateway, "whoami").stdout


def test_an_id_token_is_not_a_sign_in(gateway: Gateway, pool: Pool) -> None:
    pool.invite("ada")
    answer = pool.client.admin_initiate_auth(
        UserPoolId=pool.id, ClientId=pool.client_id, AuthFlow="ADMIN_NO_SRP_AUTH",
        AuthParameters={"USERNAME": "ada", "PASSWORD": TEMPORARY})
    session = answer["Session"]
    result = pool.client.admin_respond_to_auth_challenge(
        UserPoolId=pool.id, ClientId=pool.client_id, ChallengeName="NEW_PASSWORD_REQUIRED",
        ChallengeResponses={"USERNAME": "ada", "NEW_PASSWORD": CHOSEN}, Session=session,
    )["AuthenticationResult"]
    request = urllib.request.Request(f"{gateway.url}/cognito/me",
                                     headers={"Authorization": f"Bearer {result['IdToken']}"})
    with pytest.raises(urllib.error.HTTPError) as refused:
        urllib.request.urlopen(request, timeout=10)
    assert refused.value.code in (401, 403)


def test_login_tells_a_serve_board_from_a_deployed_one(tmp_path: Path) -> None:
    from drboard_cli.joins import JoinDesk
    from drboard_cli.serve import BoardServer

    store = SqliteStore(":memory:")
    desk = JoinDesk(tmp_path / "joined.sqlite")
    server = BoardServer(("127.0.0.1", 0), LeaderboardService(store), desk)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        url = f"http://127.0.0.1:{server.server_address[1]}"
        result = CliRunner().invoke(cli, ["--endpoint", url, "login", "--password"])
        assert result.exit_code == 1 and "drboard join CODE" in result.stderr
    finally:
        server.shutdown()
        server.server_close()
        desk.close()
        store.close()


# ---- the browser sign-in: authorization code with PKCE on a loopback redirect ------------------


class HostedSignIn(ThreadingHTTPServer):
    """The pool's hosted sign-in page and token endpoint, as far as the CLI sees them."""

    daemon_threads = True

    def __init__(self, access_token: str) -> None:
        super().__init__(("127.0.0.1", 0), _HostedHandler)
        self.access_token = access_token
        self.challenge: str | None = None
        self.verified = False


class _HostedHandler(BaseHTTPRequestHandler):
    server: HostedSignIn

    def do_POST(self) -> None:
        form = parse_qs(self.rfile.read(int(self.headers["Content-Length"])).decode())
        verifier = form["code_verifier"][0]
        digest = base64.urlsafe_b64encode(hashlib.sha256(verifier.encode()).digest()).rstrip(b"=")
        self.server.verified = (digest.decode() == self.server.challenge
                                and form["code"][0] == "the-code"
                                and form["grant_type"][0] == "authorization_code")
        body = json.dumps({"access_token": self.server.access_token, "refresh_token": "refresh",
                           "token_type": "Bearer", "expires_in": 3600}).encode()
        self.send_response(200 if self.server.verified else 400)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.end_headers()
        self.wfile.write(body)

    def log_message(self, format: str, *args: Any) -> None:
        pass


def _unsigned_jwt(claims: dict[str, Any]) -> str:
    def part(value: dict[str, Any]) -> str:
        return base64.urlsafe_b64encode(json.dumps(value).encode()).rstrip(b"=").decode()
    return f"{part({'alg': 'none'})}.{part(claims)}.sig"


def test_browser_sign_in_uses_pkce_and_a_loopback_redirect() -> None:
    hosted = HostedSignIn(_unsigned_jwt({"username": "ada", "token_use": "access"}))
    threading.Thread(target=hosted.serve_forever, daemon=True).start()
    settings = SignIn(kind="cognito", region=REGION, user_pool_id="eu-west-1_x", client_id="cli",
                      domain=f"http://127.0.0.1:{hosted.server_address[1]}", scopes=["openid"])

    def browser(url: str) -> None:  # the racer signs in; the page sends the browser back
        query = parse_qs(urlsplit(url).query)
        assert query["code_challenge_method"] == ["S256"]
        assert query["redirect_uri"] == [signing_in.REDIRECT_URI]
        hosted.challenge = query["code_challenge"][0]
        back = f"{signing_in.REDIRECT_URI}?code=the-code&state={query['state'][0]}"
        threading.Thread(target=lambda: urllib.request.urlopen(back, timeout=10).read(),
                         daemon=True).start()

    try:
        token = signing_in.login_in_browser("https://board.example", settings, browser,
                                            open_browser=False, wait_s=10)
    finally:
        hosted.shutdown()
        hosted.server_close()
    assert hosted.verified, "the token endpoint got the verifier of the challenge"
    assert token.username == "ada" and token.refresh_token == "refresh"
    assert tokens.load("https://board.example") == token


@pytest.mark.parametrize("paste", ["address", "code"])
def test_a_headless_machine_signs_in_with_what_the_browser_shows(paste: str) -> None:
    """`drboard login --no-browser`: nothing listens on the headless machine; the racer signs in
    on another device and pastes back the address it ended on (or just its code)."""
    hosted = HostedSignIn(_unsigned_jwt({"username": "ada", "token_use": "access"}))
    threading.Thread(target=hosted.serve_forever, daemon=True).start()
    settings = SignIn(kind="cognito", region=REGION, user_pool_id="eu-west-1_x", client_id="cli",
                      domain=f"http://127.0.0.1:{hosted.server_address[1]}", scopes=["openid"])
    shown: list[str] = []

    def pasted() -> str:
        query = parse_qs(urlsplit(shown[0]).query)
        hosted.challenge = query["code_challenge"][0]
        address = f"{signing_in.REDIRECT_URI}?code=the-code&state={query['state'][0]}"
        return f"  {address}\n" if paste == "address" else "the-code"

    try:
        token = signing_in.login_with_pasted_code("https://board.example", settings, shown.append,
                                                  pasted)
    finally:
        hosted.shutdown()
        hosted.server_close()
    assert hosted.verified and token.username == "ada"
    assert tokens.load("https://board.example") == token


def test_a_pasted_address_of_another_sign_in_is_refused() -> None:
    with pytest.raises(errors.NotAuthorized, match="another sign-in"):
        signing_in.pasted_redirect(f"{signing_in.REDIRECT_URI}?code=c&state=other", "mine")
    with pytest.raises(errors.NotSignedIn):
        signing_in.pasted_redirect("   ", "mine")
