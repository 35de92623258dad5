"""Who a request is signed in as: what the authorizer context of each edge gives the service."""

from __future__ import annotations

from typing import Any

import pytest
from drboard_functions.identity import Caller, caller_from_event


def event(authorizer: dict[str, Any] | None) -> dict[str, Any]:
    context: dict[str, Any] = {"requestId": "r1"}
    if authorizer is not None:
        context["authorizer"] = authorizer
    return {"requestContext": context}


def jwt(**claims: Any) -> dict[str, Any]:
    return {"jwt": {"claims": claims, "scopes": None}}


def test_a_cognito_access_token_is_a_racer() -> None:
    caller = caller_from_event(event(jwt(sub="abc", token_use="access", username="speedy")))
    assert caller == Caller(principal="cognito:abc", name="speedy", organiser=False)


@pytest.mark.parametrize("groups", [["organisers"], "[organisers racers]", "[racers organisers]"])
def test_the_organisers_group_makes_an_organiser(groups: Any) -> None:
    caller = caller_from_event(event(jwt(sub="abc", token_use="access", **{"cognito:groups": groups})))
    assert caller is not None and caller.organiser


def test_another_group_is_not_an_organiser() -> None:
    caller = caller_from_event(event(jwt(sub="abc", token_use="access", **{"cognito:groups": "[racers]"})))
    assert caller is not None and not caller.organiser


def test_an_id_token_is_not_a_sign_in() -> None:
    assert caller_from_event(event(jwt(sub="abc", token_use="id", email="a@example.com"))) is None


def test_an_iam_signed_request_is_an_organiser() -> None:
    arn = "arn:aws:sts::123456789012:assumed-role/org/ada"
    assert caller_from_event(event({"iam": {"userArn": arn}})) == Caller(
        principal=f"iam:{arn}", name=arn, organiser=True)


def test_serve_says_who_is_at_the_computer() -> None:
    caller = caller_from_event(event({"lambda": {"principal": "local", "organiser": True}}))
    assert caller is not None and caller.principal == "local" and caller.organiser


def test_no_authorizer_is_anonymous() -> None:
    assert caller_from_event(event(None)) is None
    assert caller_from_event({}) is None
