"""The SAM template and the code agree: each function's routes, environment and permissions.

The template is translated to CloudFormation with aws-sam-translator (offline), then each handler
runs on moto with only the environment the template gives it, while every AWS call it makes is
checked against the IAM policy the template grants that function.
"""

from __future__ import annotations

import copy
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import boto3
import pytest
from drboard_cli.serve import LocalContext
from moto import mock_aws
from samtranslator.parser.parser import Parser
from samtranslator.translator.translator import Translator
from samtranslator.yaml_helper import yaml_parse

from tests.tablekit import create_board_table

ROOT = Path(__file__).parents[2]
EVENTS = ROOT / "events"
FUNCTIONS = {"PushFunction": "push", "PullFunction": "pull"}


@pytest.fixture(scope="module")
def sam() -> dict[str, Any]:
    return yaml_parse((ROOT / "template.yaml").read_text())


@pytest.fixture(scope="module")
def cloudformation(sam: dict[str, Any]) -> dict[str, Any]:
    template = copy.deepcopy(sam)
    for resource in template["Resources"].values():
        if resource["Type"] == "AWS::Serverless::Function":
            resource["Properties"]["CodeUri"] = "s3://bucket/code.zip"  # as `sam package` does
    translator = Translator({}, Parser(), boto_session=boto3.Session(region_name="us-east-1"))
    translated: dict[str, Any] = translator.translate(
        template, parameter_values={}, get_managed_policy_map=lambda: {})
    return translated


def _app_routes(kind: str) -> set[tuple[str, str]]:
    from drboard_functions.routes import build_app, pull_router, push_router

    app = build_app(push_router if kind == "push" else pull_router)
    paths = json.loads(app.get_openapi_json_schema())["paths"]
    return {(method.upper(), path) for path, methods in paths.items() for method in methods}


def _template_routes(sam: dict[str, Any], function: str) -> set[tuple[str, str]]:
    events = sam["Resources"][function]["Properties"]["Events"].values()
    return {(e["Properties"]["Method"].upper(), e["Properties"]["Path"])
            for e in events if e["Type"] == "HttpApi"}


@pytest.mark.parametrize("function", FUNCTIONS)
def test_each_function_serves_the_routes_its_resolver_has(sam: dict[str, Any], function: str) -> None:
    assert _template_routes(sam, function) == _app_routes(FUNCTIONS[function])


def test_only_the_push_route_requires_iam_authorisation(cloudformation: dict[str, Any]) -> None:
    (api,) = [r for r in cloudformation["Resources"].values() if r["Type"] == "AWS::ApiGatewayV2::Api"]
    paths = api["Properties"]["Body"]["paths"]
    for path, methods in paths.items():
        for method, operation in methods.items():
            if method == "x-amazon-apigateway-any-method":
                continue
            auth = operation.get("security") or operation.get("x-amazon-apigateway-auth")
            if (method, path) == ("post", "/boards/{board}/submissions"):
                assert auth == {"type": "AWS_IAM"} or auth == [{"AWS_IAM": []}], auth
            else:
                assert not auth, (method, path, auth)


def test_functions_run_on_python_313_arm64(cloudformation: dict[str, Any]) -> None:
    for name in FUNCTIONS:
        properties = cloudformation["Resources"][name]["Properties"]
        assert properties["Runtime"] == "python3.13"
        assert properties["Architectures"] == ["arm64"]


def test_the_table_and_the_bucket_outlive_the_stack(sam: dict[str, Any]) -> None:
    for name in ("BoardTable", "ArchiveBucket"):
        resource = sam["Resources"][name]
        assert resource["DeletionPolicy"] == "Retain"
        assert resource["UpdateReplacePolicy"] == "Retain"
    table = sam["Resources"]["BoardTable"]["Properties"]
    assert table["PointInTimeRecoverySpecification"]["PointInTimeRecoveryEnabled"] is True
    assert table["SSESpecification"]["SSEEnabled"] is True
    assert table["BillingMode"] == "PAY_PER_REQUEST"
    bucket = sam["Resources"]["ArchiveBucket"]["Properties"]
    assert bucket["VersioningConfiguration"]["Status"] == "Enabled"
    assert all(bucket["PublicAccessBlockConfiguration"].values())


# ---- each handler with only its template environment and its template permissions ------------


class CallRecorder:
    """Records (IAM action, resource kind) for every AWS call made through boto3 clients."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, str]] = []

    def __call__(self, model: Any, params: dict[str, Any], **_: Any) -> None:
        service = model.service_model.endpoint_prefix
        operation = model.name
        if operation == "TransactWriteItems":
            kinds = {"Put": "PutItem", "Update": "UpdateItem", "Delete": "DeleteItem",
                     "ConditionCheck": "ConditionCheckItem"}
            for item in params["TransactItems"]:
                (kind,) = item
                self.calls.append((f"dynamodb:{kinds[kind]}", "table"))
            return
        resource = "index" if params.get("IndexName") else "table"
        if service == "s3":
            resource = "object"
        self.calls.append((f"{service}:{operation}", resource))


def _granted(cloudformation: dict[str, Any], function: str) -> set[tuple[str, str]]:
    role = cloudformation["Resources"][f"{function}Role"]["Properties"]
    granted: set[tuple[str, str]] = set()
    for policy in role.get("Policies", []):
        for statement in policy["PolicyDocument"]["Statement"]:
            actions = statement["Action"]
            resources = statement["Resource"]
            for action in [actions] if isinstance(actions, str) else actions:
                for resource in resources if isinstance(resources, list) else [resources]:
                    granted.add((action, _resource_kind(resource)))
    return granted


def _resource_kind(resource: Any) -> str:
    text = json.dumps(resource)
    if "/index/" in text:
        return "index"
    if "ArchiveBucket" in text:
        return "object"
    return "table"


def _environment(cloudformation: dict[str, Any], function: str, names: dict[str, str]) -> dict[str, str]:
    variables = cloudformation["Resources"][function]["Properties"]["Environment"]["Variables"]
    resolved = {}
    for key, value in variables.items():
        if isinstance(value, dict) and "Ref" in value:
            value = names.get(value["Ref"], value["Ref"])
        resolved[key] = str(value)
    return resolved


@pytest.fixture
def aws(monkeypatch: pytest.MonkeyPatch) -> Iterator[CallRecorder]:
    for variable in ("AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY", "AWS_SESSION_TOKEN"):
        monkeypatch.setenv(variable, "testing")
    monkeypatch.setenv("AWS_DEFAULT_REGION", "us-east-1")
    monkeypatch.setenv("POWERTOOLS_TRACE_DISABLED", "true")
    recorder = CallRecorder()
    real_client = boto3.client

    def recording_client(*args: Any, **kwargs: Any) -> Any:
        client = real_client(*args, **kwargs)
        client.meta.events.register("before-parameter-build", recorder)
        return client

    with mock_aws():
        monkeypatch.setattr(boto3, "client", recording_client)
        yield recorder


@pytest.fixture
def deployed(aws: CallRecorder, sam: dict[str, Any]) -> dict[str, str]:
    """The names Refs resolve to: the resources made on moto, and the parameters' defaults."""
    names = {name: str(p["Default"]) for name, p in sam.get("Parameters", {}).items()}
    names |= {"BoardTable": "drboard-BoardTable", "ArchiveBucket": "drboard-archive"}
    create_board_table(boto3.client("dynamodb"), names["BoardTable"])
    boto3.client("s3").create_bucket(Bucket=names["ArchiveBucket"])
    aws.calls.clear()
    return names


def _invoke(kind: str, event_file: str) -> dict[str, Any]:
    from drboard_functions.handlers import pull, push, wiring

    wiring.service_from_environment.cache_clear()
    handler = push.lambda_handler if kind == "push" else pull.lambda_handler
    event = json.loads((EVENTS / event_file).read_text())
    result: dict[str, Any] = handler(event, LocalContext())
    return result


def _isolate(monkeypatch: pytest.MonkeyPatch, environment: dict[str, str]) -> None:
    for variable in ("TABLE_NAME", "ARCHIVE_BUCKET"):
        monkeypatch.delenv(variable, raising=False)
    for key, value in environment.items():
        monkeypatch.setenv(key, value)


def test_push_works_with_its_template_environment_and_permissions(
    cloudformation: dict[str, Any], deployed: dict[str, str], aws: CallRecorder,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _isolate(monkeypatch, _environment(cloudformation, "PushFunction", deployed))
    result = _invoke("push", "push.json")
    assert result["statusCode"] == 201, result["body"]
    used = set(aws.calls)
    granted = _granted(cloudformation, "PushFunction")
    archived = boto3.client("s3").list_objects_v2(Bucket=deployed["ArchiveBucket"])
    assert archived["KeyCount"] == 1, "every accepted record is archived"
    assert used <= granted, f"calls not allowed by the template: {used - granted}"


def test_pull_works_with_its_template_environment_and_permissions(
    cloudformation: dict[str, Any], deployed: dict[str, str], aws: CallRecorder,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _isolate(monkeypatch, _environment(cloudformation, "PushFunction", deployed))
    assert _invoke("push", "push.json")["statusCode"] == 201
    aws.calls.clear()
    _isolate(monkeypatch, _environment(cloudformation, "PullFunction", deployed))
    for event_file in sorted(p.name for p in EVENTS.glob("pull*.json")):
        result = _invoke("pull", event_file)
        assert result["statusCode"] == 200, (event_file, result["body"][:300])
    granted = _granted(cloudformation, "PullFunction")
    used = set(aws.calls)
    assert used, "the pull function reads the table"
    assert used <= granted, f"calls not allowed by the template: {used - granted}"
    assert not any(action.startswith(("s3:", "dynamodb:Put", "dynamodb:Update"))
                   for action, _ in granted), "the pull function only reads"
