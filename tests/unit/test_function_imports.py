"""Each Lambda function imports only what its routes use, so its cold start pays for nothing else.

bench/bench_functions.py measures the cold starts; these tests check what a fresh process of each
handler has imported: after the import, and for the pull function after its first request too.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from drboard_assembler.record import Record
from drboard_functions.services import sqlite_service

EVENTS = Path(__file__).parents[2] / "events"

#: What no function imports: the X-Ray SDK (traces are Lambda's own).
NOWHERE = ("aws_xray_sdk",)
#: Besides NOWHERE, what each handler's import must leave alone.
NOT_IMPORTED = {
    "pull": ("drboard_functions.routes.submissions", "drboard_functions.routes.organisers",
             "drboard_functions.routes.season_changes",
             "drboard_functions.routes.webhooks", "drboard_functions.service.pushing",
             "drboard_functions.service.transfer", "drboard_functions.service.managing",
             "drboard_functions.service.moderating", "drboard_functions.service.aliases",
             "drboard_functions.service.webhooks", "drboard_functions.models.transfer",
             "drboard_functions.models.requests", "drboard_functions.models.notices",
             "drboard_functions.notify", "drboard_functions.charts", "regex", "disarm", "jinja2"),
    "push": ("drboard_functions.routes.boards", "drboard_functions.routes.pages",
             "drboard_functions.routes.results", "drboard_functions.routes.organisers",
             "drboard_functions.routes.webhooks", "drboard_functions.web",
             "drboard_functions.service.transfer", "drboard_functions.service.managing",
             "drboard_functions.service.moderating", "drboard_functions.service.webhooks",
             "drboard_functions.models.transfer",
             "drboard_functions.notify", "jinja2"),
    "admin": ("drboard_functions.routes.boards", "drboard_functions.routes.pages",
              "drboard_functions.routes.seasons", "drboard_functions.season_page",
              "drboard_functions.routes.results", "drboard_functions.routes.submissions",
              "drboard_functions.web", "jinja2"),
}

LAMBDA_ENVIRONMENT = {"POWERTOOLS_SERVICE_NAME": "drboard", "POWERTOOLS_METRICS_NAMESPACE": "drboard",
                      "AWS_LAMBDA_FUNCTION_NAME": "drboard-test", "TABLE_NAME": "unused"}

#: What the Makefile leaves out of each function's bundle (NOT_SHIPPED_<Function>).
NOT_SHIPPED = {"pull": ["regex", "disarm"], "push": ["jinja2", "markupsafe", "segno"],
               "admin": ["jinja2", "markupsafe", "segno"]}

#: Run in a fresh process: import the handler, answer events on an SQLite board (the wiring
#: swapped as in test_handlers) with some libraries missing, and tell the modules loaded, the
#: answers' statuses, whether the Record's schema was built, and whether the cycle collector ran
#: after the import and after the answers (and how many objects it was kept from).
PROBE = """
import json, sys
from importlib.abc import MetaPathFinder
from pathlib import Path
kind, db, missing, events = sys.argv[1], sys.argv[2], sys.argv[3].split(), sys.argv[4:]

class Missing(MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in missing:
            raise ModuleNotFoundError(f"No module named {name!r} (not in the bundle)", name=name)
        return None

sys.meta_path.insert(0, Missing())
handler = __import__("drboard_functions.handlers." + kind, fromlist=["lambda_handler"])
imported = sorted(sys.modules)
import gc
collector = {"after_import": gc.isenabled()}
from functools import cache
from drboard_functions.handlers import wiring
from drboard_functions.services import sqlite_service
wiring.service_from_environment = cache(lambda: sqlite_service(Path(db)))
def kept_pages():
    from drboard_functions.routes.standings import standings_of
    return standings_of(wiring.service_from_environment()).pages
wiring.kept_pages_from_environment = kept_pages
class Context:
    function_name = "drboard-test"; function_version = "$LATEST"; memory_limit_in_mb = 512
    invoked_function_arn = "arn:aws:lambda:us-east-1:123456789012:function:drboard-test"
    aws_request_id = "test"; log_group_name = "test"; log_stream_name = "test"
answered = {Path(event).name: handler.lambda_handler(json.loads(Path(event).read_text()),
                                                    Context())["statusCode"] for event in events}
collector |= {"after_answers": gc.isenabled(), "frozen": gc.get_freeze_count()}
from drboard_assembler.record import Record
print(json.dumps({"imported": imported, "answered": answered, "loaded": sorted(sys.modules),
                  "record_schema_built": Record.__pydantic_complete__, "collector": collector}))
"""


def probe(kind: str, db: Path | None = None, *events: str, missing: tuple[str, ...] = (),
          runtime: dict[str, str] | None = None) -> dict[str, object]:
    """What a fresh process of the handler loads and answers; ``runtime``: the variables the
    Lambda runtime sets besides (none: a process that is no function's, a test's or a server's)."""
    arguments = [kind, str(db or ""), " ".join(missing), *(str(EVENTS / event) for event in events)]
    environment = {name: value for name, value in os.environ.items() if name != "AWS_EXECUTION_ENV"}
    done = subprocess.run([sys.executable, "-c", PROBE, *arguments], capture_output=True, text=True,
                          check=False, env=environment | LAMBDA_ENVIRONMENT | (runtime or {}))
    assert done.returncode == 0, done.stderr
    found: dict[str, object] = json.loads(done.stdout.splitlines()[-1])
    return found


def among(modules: object, prefixes: tuple[str, ...]) -> list[str]:
    assert isinstance(modules, list)
    return [m for m in modules if m.startswith(prefixes)]


@pytest.mark.parametrize("kind", sorted(NOT_IMPORTED))
def test_a_handler_imports_only_its_own_routes_and_rooms(kind: str) -> None:
    found = probe(kind)
    assert among(found["imported"], NOT_IMPORTED[kind] + NOWHERE) == []


def event_record() -> Record:
    return Record.model_validate_json(json.loads((EVENTS / "push.json").read_text())["body"])


@pytest.fixture
def board_with_a_push(tmp_path: Path) -> Path:
    db = tmp_path / "board.db"
    sqlite_service(db).push(event_record())
    return db


def test_the_pull_function_answers_the_standings_without_the_record_schema(board_with_a_push: Path) -> None:
    """The standings hold entries, not records: the pull's first request builds no Record schema
    and loads no push, organiser or webhook code."""
    found = probe("pull", board_with_a_push, "pull_board.json")
    assert found["answered"] == {"pull_board.json": 200}
    assert among(found["loaded"], NOT_IMPORTED["pull"] + NOWHERE) == []
    assert found["record_schema_built"] is False


def test_the_admin_function_loads_only_the_routes_of_the_request(tmp_path: Path) -> None:
    """A cold admin function creating a board loads the organisers' routes, not the seasons' nor
    the webhooks'; the seasons' load when a season request comes (and the boards' still answer)."""
    found = probe("admin", tmp_path / "board.db", "admin_create_board.json")
    assert found["answered"] == {"admin_create_board.json": 201}
    assert among(found["loaded"], ("drboard_functions.routes.season_changes",
                                   "drboard_functions.routes.webhooks")) == []
    found = probe("admin", tmp_path / "board.db", "admin_create_season.json", "admin_update_board.json")
    assert found["answered"] == {"admin_create_season.json": 201, "admin_update_board.json": 200}
    assert "drboard_functions.routes.season_changes" in found["loaded"]


def test_a_push_to_a_board_in_no_season_loads_no_season_webhook_or_unicode_table(tmp_path: Path) -> None:
    """A cold push of an ASCII alias to a board that is no season's final leaves out the seasons'
    models and rules, the live board's notices, and the Unicode tables of regex and disarm; and
    the views it never answers with (a racer's pages, the organisers'), whose classes it would
    otherwise define at every cold start."""
    found = probe("push", tmp_path / "board.db", "push.json")
    assert found["answered"] == {"push.json": 201}
    assert among(found["loaded"], ("drboard_functions.models.seasons", "drboard_functions.service.seasons",
                                   "drboard_functions.models.notices", "regex", "disarm")) == []
    assert among(found["loaded"], ("drboard_functions.service.racers", "drboard_functions.insights",
                                   "drboard_functions.models.racer_views",
                                   "drboard_functions.models.organiser_views")) == []


#: What the Lambda runtime sets that tells a function's container (Python 3.13's).
LAMBDA_RUNTIME = {"AWS_EXECUTION_ENV": "AWS_Lambda_python3.13"}


@pytest.mark.parametrize(("kind", "event", "status"), [
    ("push", "push.json", 201), ("pull", "pull_board.json", 200),
    ("admin", "admin_create_board.json", 201)])
def test_a_cold_start_in_lambda_runs_without_the_cycle_collector_until_its_first_answer(
        tmp_path: Path, kind: str, event: str, status: int) -> None:
    """The collector sleeps through the import and the first request, then runs again with what
    the cold start loaded frozen out of its way."""
    db = tmp_path / "board.db"
    if kind == "pull":
        sqlite_service(db).push(event_record())
    found = probe(kind, db, event, runtime=LAMBDA_RUNTIME)
    assert found["answered"] == {event: status}
    collector = found["collector"]
    assert isinstance(collector, dict)
    assert (collector["after_import"], collector["after_answers"]) == (False, True)
    assert collector["frozen"] > 10_000


def test_importing_a_handler_elsewhere_leaves_the_cycle_collector_alone(tmp_path: Path) -> None:
    found = probe("push", tmp_path / "board.db", "push.json")
    assert found["answered"] == {"push.json": 201}
    assert found["collector"] == {"after_import": True, "after_answers": True, "frozen": 0}


def test_each_admin_route_is_found_in_the_module_that_declares_it() -> None:
    from drboard_functions.routes import admin_router, admin_routes_module, build_app

    app = build_app(admin_router)
    routes = app._static_routes + app._dynamic_routes
    assert len(routes) > 30
    for route in routes:
        path = route.path.replace("<", "").replace(">", "")  # /boards/<board> -> /boards/board
        declared_in = route.func.__module__.rpartition(".")[2]
        assert admin_routes_module(path) == declared_in, route.path


def answered_by(handler: str) -> str:
    """The end of a probe: the handler answers the event in ``argv[1]`` with a Lambda context,
    and the answer and the modules loaded are printed as JSON."""
    return f"""
class Context:
    function_name = "drboard-test"; function_version = "$LATEST"; memory_limit_in_mb = 512
    invoked_function_arn = "arn:aws:lambda:us-east-1:123456789012:function:drboard-test"
    aws_request_id = "test"; log_group_name = "test"; log_stream_name = "test"
with open(sys.argv[1]) as file:
    answer = {handler}.lambda_handler(json.load(file), Context())
print(json.dumps({{"answer": answer, "loaded": sorted(sys.modules)}}))
"""


#: Run in a fresh process: the pull function answering a page its table keeps (a shelf in
#: memory here, as DynamoDB's answers it), and what that loaded.
KEPT_PROBE = """
import json, sys
from datetime import UTC, datetime
from drboard_functions.handlers import pull, wiring
from drboard_functions.routes.kept import KeptPages
from drboard_functions.stores.pages import StoredPage
page = StoredPage(3, None, '"etag"', {"Content-Type": "application/json", "ETag": '"etag"'},
                  {"ETag": '"etag"'}, '{"board": "kept"}')
class Shelf:
    def version(self, board_id):
        return 3
    def page(self, board_id, key):
        return 3, page if key == "json#25" else None
shelf = Shelf()
wiring.kept_pages_from_environment = lambda: KeptPages(shelf.version, shelf, lambda: datetime.now(UTC))
""" + answered_by("pull")


def test_the_pull_function_answers_a_kept_page_before_loading_the_resolver_or_pydantic() -> None:
    done = subprocess.run([sys.executable, "-c", KEPT_PROBE, str(EVENTS / "pull_board.json")],
                          capture_output=True, text=True, check=False,
                          env={**os.environ, **LAMBDA_ENVIRONMENT})
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.splitlines()[-1])
    assert (found["answer"]["statusCode"], found["answer"]["body"]) == (200, '{"board": "kept"}')
    assert among(found["loaded"], ("pydantic", "aws_lambda_powertools.event_handler",
                                   "drboard_functions.models", "drboard_functions.service.",
                                   "drboard_assembler.record", "jinja2")) == []
    assert "drboard_functions.service" not in found["loaded"], "no service is built"


#: Run in a fresh process: the card function drawing a racer's card from the standings its
#: table keeps (a shelf in memory holding the page given in a file), and what that loaded.
CARD_PROBE = """
import json, sys
from datetime import UTC, datetime
from drboard_functions.handlers import card, wiring
from drboard_functions.routes.kept import KeptCards, KeptPages
from drboard_functions.stores.pages import StoredPage
with open(sys.argv[2]) as file:
    page = StoredPage(**json.load(file))
class Shelf:
    def version(self, board_id):
        return page.version
    def page(self, board_id, key):
        return page.version, page if key == "json#100" else None
shelf = Shelf()
pages = KeptPages(shelf.version, shelf, lambda: datetime.now(UTC))
def draw(svg):
    from drboard_functions.cards.png import render
    return render(svg)
wiring.kept_cards_from_environment = lambda: KeptCards(pages, draw)
""" + answered_by("card")


def test_the_card_function_draws_a_kept_card_before_loading_the_resolver_or_pydantic(
        board_with_a_push: Path, tmp_path: Path) -> None:
    from drboard_functions.routes.kept import DEFAULT_LIMIT, Wanted
    from drboard_functions.routes.standings import standings_of

    service = sqlite_service(board_with_a_push)
    board = json.loads((EVENTS / "card_racer.json").read_text())["pathParameters"]["board"]
    kept = standings_of(service).copy(Wanted(board, "json", DEFAULT_LIMIT))
    page = tmp_path / "page.json"
    page.write_text(json.dumps({"version": kept.version, "fresh_until": None, "etag": kept.etag,
                                "headers": kept.headers, "not_modified_headers": kept.not_modified_headers,
                                "text": kept.text}))
    done = subprocess.run([sys.executable, "-c", CARD_PROBE, str(EVENTS / "card_racer.json"), str(page)],
                          capture_output=True, text=True, check=False,
                          env={**os.environ, **LAMBDA_ENVIRONMENT})
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.splitlines()[-1])
    assert (found["answer"]["statusCode"], found["answer"]["isBase64Encoded"]) == (200, True)
    assert found["answer"]["headers"]["Content-Type"] == "image/png"
    loaded = [m for m in found["loaded"] if m != "drboard_functions.models.kinds"]
    assert among(loaded, ("pydantic", "aws_lambda_powertools.event_handler",
                          "drboard_functions.models.", "drboard_functions.service.",
                          "drboard_assembler.record")) == []
    assert "drboard_functions.service" not in loaded, "no service is built"


#: Each function's events that need only a board holding the example push (test_handlers runs
#: the others, in order).
EVENTS_OF = {"pull": sorted(p.name for p in EVENTS.glob("pull_*.json")), "push": ["push.json"],
             "admin": ["admin_create_board.json", "admin_import_submission.json", "admin_audit.json",
                       "admin_export_board.json"]}


@pytest.mark.parametrize("kind", sorted(NOT_SHIPPED))
def test_a_function_answers_without_what_its_bundle_leaves_out(kind: str, tmp_path: Path) -> None:
    """The Makefile leaves the name checks' libraries out of the pull function and the pages'
    out of the others: each function's events are answered as well without them."""
    db = tmp_path / "board.db"
    if kind != "push":
        sqlite_service(db).push(event_record())
    found = probe(kind, db, *EVENTS_OF[kind], missing=tuple(NOT_SHIPPED[kind]))
    answered = found["answered"]
    assert isinstance(answered, dict)
    assert all(status < 500 for status in answered.values()), answered
    assert among(found["loaded"], tuple(NOT_SHIPPED[kind])) == []
