"""The SAM template and the code agree: each function's routes, environment and permissions.

The template is translated to CloudFormation with aws-sam-translator (offline), then each handler
runs on moto with only the environment the template gives it, while every AWS call it makes is
checked against the IAM policy the template grants that function.
"""

from __future__ import annotations

import copy
import json
import re
import time
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

COGNITO_PREFIX = "/cognito"

ROOT = Path(__file__).parents[2]
EVENTS = ROOT / "events"
FUNCTIONS = {"PushFunction": "push", "PullFunction": "pull", "AdminFunction": "admin", "CardFunction": "card"}


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


def _app_operations(kind: str) -> dict[tuple[str, str], dict[str, Any]]:
    """(METHOD, path) -> OpenAPI operation of the routes the function's resolver serves."""
    from drboard_functions.routes import admin_router, build_app, card_router, pull_router, push_router

    router = {"push": push_router, "pull": pull_router, "admin": admin_router, "card": card_router}[kind]
    paths = json.loads(build_app(router).get_openapi_json_schema())["paths"]
    return {(method.upper(), path): operation for path, methods in paths.items()
            for method, operation in methods.items()}


def _app_routes(kind: str) -> set[tuple[str, str]]:
    return set(_app_operations(kind))


def _template_events(sam: dict[str, Any], function: str) -> list[tuple[str, str, str | None]]:
    """(METHOD, path, authorizer) of each of the function's HTTP API events."""
    events = sam["Resources"][function]["Properties"]["Events"].values()
    return [(e["Properties"]["Method"].upper(), e["Properties"]["Path"],
             (e["Properties"].get("Auth") or {}).get("Authorizer"))
            for e in events if e["Type"] == "HttpApi"]


def _template_routes(sam: dict[str, Any], function: str) -> set[tuple[str, str]]:
    """The routes the function serves, as its resolver knows them (``/cognito`` stripped)."""
    return {(method, path.removeprefix(COGNITO_PREFIX))
            for method, path, _ in _template_events(sam, function)}


@pytest.mark.parametrize("function", FUNCTIONS)
def test_each_function_serves_the_routes_its_resolver_has(sam: dict[str, Any], function: str) -> None:
    assert _template_routes(sam, function) == _app_routes(FUNCTIONS[function])


def test_every_route_of_the_code_has_one_function_in_the_template(sam: dict[str, Any]) -> None:
    from drboard_functions.routes import openapi_document

    documented = {(method.upper(), path) for path, methods in json.loads(openapi_document())["paths"].items()
                  for method in methods}
    served = [(method, path) for function in FUNCTIONS
              for method, path, _ in _template_events(sam, function)
              if not path.startswith(COGNITO_PREFIX + "/")]
    assert sorted(served) == sorted(documented), "each route once, by the function that has it"
    functions = [name for name, r in sam["Resources"].items() if r["Type"] == "AWS::Serverless::Function"]
    assert sorted(functions) == sorted([*FUNCTIONS, "NotifyFunction"]), "and the announcer, on no route"


def test_exactly_the_routes_the_code_signs_require_iam_authorisation(
        cloudformation: dict[str, Any]) -> None:
    signed = {route for kind in FUNCTIONS.values() for route, operation in _app_operations(kind).items()
              if operation.get("security") == [{"sigv4": []}]}
    assert ("POST", "/boards/{board}/submissions") in signed
    assert len(signed) == 37, "the push, /me, /me/alias, 22 organiser routes, 12 of seasons"
    (api,) = [r for r in cloudformation["Resources"].values() if r["Type"] == "AWS::ApiGatewayV2::Api"]
    paths = api["Properties"]["Body"]["paths"]
    seen = set()
    for path, methods in paths.items():
        for method, operation in methods.items():
            if method == "x-amazon-apigateway-any-method":
                continue
            seen.add((method.upper(), path))
            auth = operation.get("security") or operation.get("x-amazon-apigateway-auth")
            if path.startswith(COGNITO_PREFIX + "/"):
                assert (method.upper(), path.removeprefix(COGNITO_PREFIX)) in signed, (method, path)
                assert auth == [{"RacerSignIn": []}], (method, path, auth)
            elif (method.upper(), path) in signed:
                assert auth == {"type": "AWS_IAM"} or auth == [{"AWS_IAM": []}], (method, path, auth)
            else:
                assert not auth, (method, path, auth)
    assert signed <= seen
    assert {(m, COGNITO_PREFIX + p) for m, p in signed} <= seen, "each signed route has its twin"


def test_racers_sign_in_to_an_invite_only_pool_with_an_organisers_group(
        cloudformation: dict[str, Any]) -> None:
    resources = cloudformation["Resources"]
    pool = resources["RacerPool"]
    assert pool["DeletionPolicy"] == "Retain"
    invite_only = pool["Properties"]["AdminCreateUserConfig"]["AllowAdminCreateUserOnly"]
    assert invite_only == {"Fn::If": ["AllowSelfSignUp", False, True]}
    assert cloudformation["Parameters"]["SelfSignUp"]["Default"] == "false"
    assert resources["OrganisersGroup"]["Properties"]["GroupName"] == "organisers"
    client = resources["CliClient"]["Properties"]
    assert client["GenerateSecret"] is False, "a public client: the CLI keeps no secret"
    assert client["AllowedOAuthFlows"] == ["code"]
    assert client["CallbackURLs"] == ["http://localhost:8765/callback"]
    assert set(client["ExplicitAuthFlows"]) == {"ALLOW_USER_SRP_AUTH", "ALLOW_REFRESH_TOKEN_AUTH"}
    (api,) = [r for r in resources.values() if r["Type"] == "AWS::ApiGatewayV2::Api"]
    jwt = api["Properties"]["Body"]["components"]["securitySchemes"]["RacerSignIn"]
    config = jwt["x-amazon-apigateway-authorizer"]["jwtConfiguration"]
    assert config["issuer"] == {"Fn::Sub": "https://cognito-idp.${AWS::Region}.amazonaws.com/${RacerPool}"}
    assert config["audience"] == [{"Ref": "CliClient"}]
    assert jwt["x-amazon-apigateway-authorizer"]["identitySource"] == "$request.header.Authorization"


def test_cors_only_lets_browsers_read(sam: dict[str, Any]) -> None:
    cors = sam["Resources"]["BoardApi"]["Properties"]["CorsConfiguration"]
    assert cors["AllowMethods"] == ["GET", "OPTIONS"]
    assert cors["AllowHeaders"] == ["Content-Type"], "no Authorization, no X-Amz-*: no signed calls"
    assert not cors.get("AllowCredentials")


def test_every_function_has_its_handler_and_its_build_target(sam: dict[str, Any]) -> None:
    makefile = (ROOT / "Makefile").read_text()
    for name, kind in FUNCTIONS.items():
        properties = sam["Resources"][name]["Properties"]
        assert properties["Handler"] == f"drboard_functions.handlers.{kind}.lambda_handler"
        handler = ROOT / "functions" / "drboard_functions" / "handlers" / f"{kind}.py"
        assert "\ndef lambda_handler(" in handler.read_text()
        assert sam["Resources"][name]["Metadata"]["BuildMethod"] == "makefile"
        targets = re.search(rf"^(build-\w+ )*build-{name}( build-\w+)*:", makefile, re.MULTILINE)
        assert targets, f"the Makefile has no build-{name} target"


def test_announcements_go_out_from_the_tables_stream_with_retries_and_a_dead_letter_queue(
        sam: dict[str, Any]) -> None:
    table = sam["Resources"]["BoardTable"]["Properties"]
    assert table["StreamSpecification"]["StreamViewType"] == "NEW_AND_OLD_IMAGES"
    assert table["TimeToLiveSpecification"] == {"AttributeName": "expires_at", "Enabled": True}
    notify = sam["Resources"]["NotifyFunction"]["Properties"]
    assert notify["Handler"] == "drboard_functions.handlers.notify.lambda_handler"
    stream = notify["Events"]["EntryChanges"]["Properties"]
    assert stream["FunctionResponseTypes"] == ["ReportBatchItemFailures"]
    assert stream["MaximumRetryAttempts"] >= 1 and stream["BisectBatchOnFunctionError"] is True
    assert stream["DestinationConfig"]["OnFailure"]["Type"] == "SQS"
    pattern = json.loads(stream["FilterCriteria"]["Filters"][0]["Pattern"])
    assert pattern["dynamodb"]["Keys"]["sk"]["S"] == [{"prefix": "R#"}], "entries only"
    schedule = notify["Events"]["BoardWindows"]
    assert schedule["Type"] == "ScheduleV2"
    assert json.loads(schedule["Properties"]["Input"]) == {"check": "windows"}
    assert re.search(r"^build-\w+( build-\w+)* build-NotifyFunction:|build-NotifyFunction",
                     (ROOT / "Makefile").read_text(), re.MULTILINE)


def test_functions_run_on_python_313_arm64(cloudformation: dict[str, Any]) -> None:
    for name in [*FUNCTIONS, "NotifyFunction"]:
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


def test_the_archive_expires_versions_that_are_no_longer_current(sam: dict[str, Any]) -> None:
    rules = sam["Resources"]["ArchiveBucket"]["Properties"]["LifecycleConfiguration"]["Rules"]
    expiring = [rule for rule in rules if rule["Status"] == "Enabled"
                and "NoncurrentVersionExpiration" in rule]
    assert expiring and expiring[0]["NoncurrentVersionExpiration"]["NoncurrentDays"] == {
        "Ref": "ArchiveOldVersionDays"}
    assert sam["Parameters"]["ArchiveOldVersionDays"]["Default"] == 30


def test_the_api_is_throttled_logged_and_its_functions_reserved(
        sam: dict[str, Any], cloudformation: dict[str, Any]) -> None:
    parameters = sam["Parameters"]
    stage = next(resource["Properties"] for resource in cloudformation["Resources"].values()
                 if resource["Type"] == "AWS::ApiGatewayV2::Stage")
    assert stage["DefaultRouteSettings"] == {"ThrottlingRateLimit": {"Ref": "ApiRateLimit"},
                                             "ThrottlingBurstLimit": {"Ref": "ApiBurstLimit"}}
    assert stage["AccessLogSettings"]["DestinationArn"] == {"Fn::GetAtt": ["ApiAccessLog", "Arn"]}
    assert "$context.status" in stage["AccessLogSettings"]["Format"]
    assert sam["Resources"]["ApiAccessLog"]["Properties"]["RetentionInDays"] == {"Ref": "AccessLogDays"}
    for function, parameter in (("PushFunction", "PushConcurrency"), ("PullFunction", "PullConcurrency"),
                                ("AdminFunction", "AdminConcurrency")):
        reserved = sam["Resources"][function]["Properties"]["ReservedConcurrentExecutions"]
        assert reserved["Fn::If"][1] == {"Ref": parameter}
        assert int(parameters[parameter]["Default"]) > 0
    assert 0 < int(parameters["ApiRateLimit"]["Default"]) <= int(parameters["ApiBurstLimit"]["Default"])


def test_an_optional_cdn_keeps_only_what_the_board_says_and_passes_signed_calls_through(
        sam: dict[str, Any], cloudformation: dict[str, Any]) -> None:
    from drboard_functions.routes.headers import PUBLIC_CACHE

    parameter = sam["Parameters"]["CdnDistribution"]
    assert (parameter["Default"], sorted(parameter["AllowedValues"])) == ("false", ["false", "true"])
    assert sam["Conditions"]["WithCdn"] == {"Fn::Equals": [{"Ref": "CdnDistribution"}, "true"]}
    resources = cloudformation["Resources"]
    cdn = {name: resources[name] for name in ("PublicReadsCachePolicy", "ApiRequestPolicy", "BoardCdn")}
    assert all(resource["Condition"] == "WithCdn" for resource in cdn.values())
    assert cloudformation["Outputs"]["CdnUrl"]["Condition"] == "WithCdn"

    # Kept as long as the board's own Cache-Control says, and never past a few seconds; an
    # answer that says nothing (signed, organiser, errors) is not kept at all.
    policy = cdn["PublicReadsCachePolicy"]["Properties"]["CachePolicyConfig"]
    max_age = int(re.search(r"max-age=(\d+)", PUBLIC_CACHE)[1])  # type: ignore[index]
    assert policy["MinTTL"] == policy["DefaultTTL"] == 0 and max_age <= policy["MaxTTL"] <= 5
    key = policy["ParametersInCacheKeyAndForwardedToOrigin"]
    assert key["QueryStringsConfig"] == {"QueryStringBehavior": "all"}
    assert set(key["HeadersConfig"]["Headers"]) == {"Authorization", "Origin"}  # forwarded, never shared
    assert key["CookiesConfig"] == {"CookieBehavior": "none"}

    config = cdn["BoardCdn"]["Properties"]["DistributionConfig"]
    [origin] = config["Origins"]
    assert origin["DomainName"] == {"Fn::Sub": "${BoardApi}.execute-api.${AWS::Region}.${AWS::URLSuffix}"}
    assert origin["CustomOriginConfig"]["OriginProtocolPolicy"] == "https-only"
    default = config["DefaultCacheBehavior"]
    assert default["CachePolicyId"] == {"Ref": "PublicReadsCachePolicy"}
    assert default["OriginRequestPolicyId"] == {"Ref": "ApiRequestPolicy"}
    assert set(default["CachedMethods"]) == {"GET", "HEAD"} and "POST" in default["AllowedMethods"]
    [signed_in] = config["CacheBehaviors"]
    assert signed_in["PathPattern"] == COGNITO_PREFIX + "/*"
    assert signed_in["CachePolicyId"] == "4135ea2d-6df8-44a3-9df3-4b5a84be39ad"  # CachingDisabled
    assert {error["ErrorCachingMinTTL"] for error in config["CustomErrorResponses"]} == {0}
    assert {404, 500, 503} <= {error["ErrorCode"] for error in config["CustomErrorResponses"]}
    # The announcements link to the pages viewers read: the CDN's when there is one.
    url = sam["Resources"]["NotifyFunction"]["Properties"]["Environment"]["Variables"]["BOARD_URL"]
    assert url["Fn::If"][0] == "WithCdn" and "BoardCdn.DomainName" in url["Fn::If"][1]["Fn::Sub"]


# ---- each handler with only its template environment and its template permissions ------------


class CallRecorder:
    """Records (IAM action, resource kind) for every AWS call made through boto3 clients."""

    def __init__(self) -> None:
        self.calls: list[tuple[str, str]] = []

    def __call__(self, model: Any, params: dict[str, Any], **_: Any) -> None:
        service = model.service_model.endpoint_prefix
        operation = model.name
        if operation in ("TransactWriteItems", "TransactGetItems"):  # IAM checks each item's action
            kinds = {"Put": "PutItem", "Update": "UpdateItem", "Delete": "DeleteItem",
                     "ConditionCheck": "ConditionCheckItem", "Get": "GetItem"}
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


def pull_writes(cloudformation: dict[str, Any], function: str = "PullFunction") -> list[Any]:
    """The conditions of the function's statements that grant a write (the pull function's by
    default)."""
    role = cloudformation["Resources"][f"{function}Role"]["Properties"]
    return [statement.get("Condition") for policy in role.get("Policies", [])
            for statement in policy["PolicyDocument"]["Statement"]
            if any(a.startswith("dynamodb:Put") for a in ([statement["Action"]] if isinstance(
                statement["Action"], str) else statement["Action"]))]


def _resource_kind(resource: Any) -> str:
    text = json.dumps(resource)
    if "/index/" in text:
        return "index"
    if "ArchiveBucket" in text:
        return "object"
    return "table"


#: What the pseudo parameters of a ``!Sub`` resolve to here.
PSEUDO = {"AWS::Region": "us-east-1", "AWS::URLSuffix": "amazonaws.com", "AWS::AccountId": "123456789012"}


def _environment(cloudformation: dict[str, Any], function: str, names: dict[str, str]) -> dict[str, str]:
    variables = cloudformation["Resources"][function]["Properties"]["Environment"]["Variables"]
    resolved = {}
    for key, value in variables.items():
        if isinstance(value, dict) and "Fn::If" in value:  # the parameters' defaults: no condition holds
            value = value["Fn::If"][2]
        if isinstance(value, dict) and "Ref" in value:
            value = names.get(value["Ref"], value["Ref"])
        elif isinstance(value, dict) and isinstance(value.get("Fn::Sub"), str):
            value = re.sub(r"\$\{([^}]+)\}", lambda m: (names | PSEUDO).get(m[1], m[1]), value["Fn::Sub"])
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
    create_board_table(boto3.client("dynamodb"), names["BoardTable"], stream=True)
    boto3.client("s3").create_bucket(Bucket=names["ArchiveBucket"])
    aws.calls.clear()
    return names


def _invoke(kind: str, event_file: str, query: dict[str, str] | None = None) -> dict[str, Any]:
    """Run a function's handler on an example event (with this query string instead, if given),
    as a fresh container would: the wiring reads the environment again."""
    from drboard_functions.handlers import admin, card, pull, push, wiring

    wiring.forget()
    handler = {"push": push, "pull": pull, "admin": admin, "card": card}[kind].lambda_handler
    event = json.loads((EVENTS / event_file).read_text())
    if query is not None:
        event["queryStringParameters"] = query
        event["rawQueryString"] = "&".join(f"{name}={value}" for name, value in query.items())
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
    assert not any(action.startswith(("s3:", "dynamodb:Update", "dynamodb:Delete"))
                   for action, _ in granted), "the pull function only reads"
    assert pull_writes(cloudformation) == [{"ForAllValues:StringLike": {
        "dynamodb:LeadingKeys": ["#RESULTS#*", "#PAGE#*"]}}], "but for kept results and pages"


def test_admin_works_with_its_template_environment_and_permissions(
    cloudformation: dict[str, Any], deployed: dict[str, str], aws: CallRecorder,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _isolate(monkeypatch, _environment(cloudformation, "AdminFunction", deployed))
    for event_file, status in [
        ("admin_create_board.json", 201), ("admin_update_board.json", 200),
        ("admin_close_board.json", 200), ("admin_delete_board.json", 200),
        ("admin_restore_board.json", 200),
        ("admin_import_board.json", 201), ("admin_import_board.json", 200),
        ("admin_import_submission.json", 201), ("admin_import_submission.json", 200),
        ("admin_remove_entry.json", 200), ("admin_ban_racer.json", 200),
        ("admin_unban_racer.json", 200), ("admin_audit.json", 200),
    ]:
        result = _invoke("admin", event_file)
        assert result["statusCode"] == status, (event_file, result["body"][:300])

    records = []
    cursor: str | None = None
    while True:  # every page of the export, the records read with BatchGetItem
        result = _invoke("admin", "admin_export_board.json", {"cursor": cursor} if cursor else None)
        assert result["statusCode"] == 200, result["body"][:300]
        page = json.loads(result["body"])
        records += [line["record"]["submission_id"] for line in page["lines"] if line["kind"] == "submission"]
        cursor = page["next_cursor"]
        if cursor is None:
            break
    used = set(aws.calls)
    imported = json.loads(json.loads((EVENTS / "admin_import_submission.json").read_text())["body"])
    assert records == [imported["record"]["submission_id"]]
    archived = boto3.client("s3").list_objects_v2(Bucket=deployed["ArchiveBucket"])
    assert archived["KeyCount"] == 1, "an imported record is archived like a pushed one"

    granted = _granted(cloudformation, "AdminFunction")
    assert used <= granted, f"calls not allowed by the template: {used - granted}"
    assert {action for action, _ in used} == {action for action, _ in granted}, (
        "least privilege: every action granted is one the organiser routes use")
    assert ("dynamodb:BatchGetItem", "table") in used


def test_the_card_function_draws_a_card_with_its_template_environment_and_permissions(
    cloudformation: dict[str, Any], deployed: dict[str, str], aws: CallRecorder,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _isolate(monkeypatch, _environment(cloudformation, "PushFunction", deployed))
    assert _invoke("push", "push.json")["statusCode"] == 201
    aws.calls.clear()
    _isolate(monkeypatch, _environment(cloudformation, "CardFunction", deployed))
    result = _invoke("card", "card_racer.json")
    assert result["statusCode"] == 200, result["body"][:300]
    assert result["headers"]["Content-Type"] == "image/png"
    used = set(aws.calls)
    assert used and used <= _granted(cloudformation, "CardFunction"), used
    assert not any(action.startswith(("s3:", "dynamodb:Update", "dynamodb:Delete"))
                   for action, _ in _granted(cloudformation, "CardFunction")), "cards only read"
    assert pull_writes(cloudformation, "CardFunction") == [{"ForAllValues:StringLike": {
        "dynamodb:LeadingKeys": ["#RESULTS#*"]}}], "but for the results a season keeps, as its page does"


def test_the_racer_routes_read_with_the_pull_functions_permissions(
    cloudformation: dict[str, Any], deployed: dict[str, str], aws: CallRecorder,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    _isolate(monkeypatch, _environment(cloudformation, "PushFunction", deployed))
    assert _invoke("push", "push.json")["statusCode"] == 201
    aws.calls.clear()
    _isolate(monkeypatch, _environment(cloudformation, "PullFunction", deployed))
    status = json.loads(_invoke("pull", "pull_racer_status.json")["body"])
    assert [entry["board"]["board_id"] for entry in status["boards"]] == ["reInvent2019_track"]
    history = json.loads(_invoke("pull", "pull_racer_history.json")["body"])
    assert len(history["history"]) == 1
    used = set(aws.calls)
    assert ("dynamodb:Query", "index") in used, "a racer's history is one query of the by_racer index"
    assert used <= _granted(cloudformation, "PullFunction")


# ---- the announcer: the table's stream of changes, as Lambda hands it to the NotifyFunction ----


def _stream_records(table: str) -> list[dict[str, Any]]:
    """Every record of the table's stream so far (moto's), as the event source mapping hands
    them to a function: with the stream's ARN, and the creation time in epoch seconds."""
    client = boto3.client("dynamodbstreams", endpoint_url="https://streams.dynamodb.us-east-1.amazonaws.com/")
    (stream,) = client.list_streams(TableName=table)["Streams"]
    arn = stream["StreamArn"]
    records = []
    for shard in client.describe_stream(StreamArn=arn)["StreamDescription"]["Shards"]:
        iterator = client.get_shard_iterator(StreamArn=arn, ShardId=shard["ShardId"],
                                             ShardIteratorType="TRIM_HORIZON")["ShardIterator"]
        for record in client.get_records(ShardIterator=iterator)["Records"]:
            change = dict(record["dynamodb"])
            created = change.get("ApproximateCreationDateTime")
            if created is not None:
                change["ApproximateCreationDateTime"] = created.timestamp()
            records.append({**record, "dynamodb": change, "eventSourceARN": arn})
    return records


def _matches(pattern: Any, value: Any) -> bool:
    """Whether an event matches an EventBridge-style filter pattern (the shapes the template's
    FilterCriteria use: nested keys, lists of values, ``{"prefix": ...}`` or ``{"exists": true}``)."""
    if isinstance(pattern, dict):
        return isinstance(value, dict) and all(name in value and _matches(inner, value[name])
                                               for name, inner in pattern.items())
    return any(option.get("exists") is True if isinstance(option, dict) and "exists" in option
               else value.startswith(option["prefix"]) if isinstance(option, dict) else value == option
               for option in pattern)


def test_notify_announces_the_streams_entry_changes_with_its_template_environment_and_permissions(
    sam: dict[str, Any], cloudformation: dict[str, Any], deployed: dict[str, str], aws: CallRecorder,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from drboard_functions import services
    from drboard_functions.handlers import notify, wiring
    from drboard_functions.models.notices import WebhookSpec

    from tests.recordkit import make_record
    from tests.unit.test_announcements import FakeChat

    _isolate(monkeypatch, _environment(cloudformation, "PushFunction", deployed))
    assert _invoke("push", "push.json")["statusCode"] == 201  # before the webhook: not announced
    board = json.loads((EVENTS / "push.json").read_text())["pathParameters"]["board"]
    time.sleep(1.01 - time.time() % 1)  # the stream's times are whole seconds: the next one
    chat = FakeChat()
    try:
        service = services.dynamodb_service(deployed["BoardTable"])
        service.add_webhook(board, WebhookSpec(kind="json", url=chat.url))
        service.push(make_record("Blaze", [(5000, 100)], model="blaze-v2"), board)
        pattern = json.loads(sam["Resources"]["NotifyFunction"]["Properties"]["Events"]["EntryChanges"]
                             ["Properties"]["FilterCriteria"]["Filters"][0]["Pattern"])
        records = [r for r in _stream_records(deployed["BoardTable"]) if _matches(pattern, r)]
        assert {r["dynamodb"]["Keys"]["board"]["S"] for r in records} == {board}, \
            "entries only: not the runs' authors (R#<racer> in #RUN#... partitions)"
        assert len(records) == 2, "each push's entry"
        aws.calls.clear()

        environment = _environment(cloudformation, "NotifyFunction", deployed)
        assert environment["BOARD_URL"].startswith("https://")
        _isolate(monkeypatch, environment)
        wiring.forget()
        answer = notify.lambda_handler({"Records": records}, LocalContext())
        assert answer == {"batchItemFailures": []}
        (body,) = chat.bodies
        assert body["event"] == "new-leader" and body["announcement"]["racer"] == "Blaze"
        assert body["text"].endswith(environment["BOARD_URL"] + f"/boards/{board}/view")
        used = set(aws.calls)
        granted = _granted(cloudformation, "NotifyFunction")
        assert used <= granted, f"calls not allowed by the template: {used - granted}"
        assert ("dynamodb:PutItem", "table") in used, "the sent marker"

        retried = notify.lambda_handler({"Records": records}, LocalContext())
        assert retried == {"batchItemFailures": []} and len(chat.bodies) == 1, "sent once"
    finally:
        chat.close()
