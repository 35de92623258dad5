"""A determined racer against the board: each attack that got through before, refused, flagged
for the organiser or answered truthfully now (issue 18). The attacks that depend on the store run
on SQLite and on DynamoDB (moto)."""

from __future__ import annotations

import json
from collections.abc import Callable, Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import boto3
import pytest
from botocore.exceptions import ClientError, ReadTimeoutError
from click.testing import CliRunner
from drboard_assembler import record as record_module
from drboard_assembler.limits import MAX_EVALUATION_RUNS
from drboard_assembler.record import EvaluationRun, Lap, Record
from drboard_cli import invite as invites
from drboard_cli.main import cli
from drboard_functions.errors import (
    AliasTaken,
    Banned,
    BoardClosed,
    CopiedRun,
    InvalidQuery,
    StoreBusy,
)
from drboard_functions.identity import Caller, caller_from_event
from drboard_functions.models.domain import Board, TimingMethod
from drboard_functions.models.requests import BoardChanges, BoardSpec, ImportedSubmission
from drboard_functions.models.views import PushAccepted, PushReceipt
from drboard_functions.routes import admin_router, build_app, pull_router, push_router
from drboard_functions.service import LeaderboardService, evaluation_fingerprints, scored_write
from drboard_functions.stores.base import BoardStore
from drboard_functions.stores.dynamodb import DynamoDbStore
from drboard_functions.stores.s3_archive import S3Archive
from drboard_functions.stores.sqlite import SqliteStore

from tests.awskit import REGION
from tests.recordkit import make_record
from tests.tablekit import create_board_table
from tests.unit.test_routes import Client

TRACK = "reInvent2019_track"
BLAZE = Caller(principal="cognito:blaze-sub", name="blaze")
COPIER = Caller(principal="cognito:copier-sub", name="copier")
STRANGER = Caller(principal="join:stranger", name="stranger")
ORGANISER = Caller(principal="iam:organiser", name="organiser", organiser=True)
LEADER_LAPS = [(8713, 100), (8655, 100), (10881, 100), (8790, 100), (8702, 100)]


class Clock:
    def __init__(self) -> None:
        self.now = datetime(2026, 3, 1, 12, 0, tzinfo=UTC)

    def __call__(self) -> datetime:
        self.now += timedelta(seconds=1)
        return self.now


@pytest.fixture(params=["sqlite", "dynamodb"])
def store(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[BoardStore]:
    if request.param == "sqlite":
        sqlite = SqliteStore(tmp_path / "board.db")
        yield sqlite
        sqlite.close()
        return
    aws = request.getfixturevalue("aws")
    assert aws is None
    db = boto3.client("dynamodb", region_name=REGION)
    yield DynamoDbStore(create_board_table(db, "boards"), client=db)


@pytest.fixture
def service(store: BoardStore) -> LeaderboardService:
    return LeaderboardService(store, clock=Clock())


def timed(record: Record) -> Record:
    """The record with start and end timestamps on each lap, as real metrics files have."""
    fields = record.model_dump(exclude={"submission_id"})
    start = 1_000.0
    for lap in fields["evaluations"][0]["laps"]:
        lap["started_ms"], lap["ended_ms"] = start, start + lap["time_ms"]
        start += lap["time_ms"] + 400
    return Record.build(**fields)


def leader(racer: str = "Blaze") -> Record:
    return timed(make_record(racer, LEADER_LAPS, model="blaze-ppo"))


def edited(record: Record, racer: str, edit: Callable[[list[dict[str, Any]]], None]) -> Record:
    """The record under another racer, its first run's laps edited (its figures recomputed)."""
    fields = record.model_dump(exclude={"submission_id"})
    fields["racer"], fields["model_name"] = racer, "totally-mine"
    run = fields["evaluations"][0]
    edit(run["laps"])
    fields["evaluations"][0] = EvaluationRun.from_laps(
        run["source"], [Lap.model_validate(lap) for lap in run["laps"]]).model_dump()
    return Record.build(**fields)


def renumbered(laps: list[dict[str, Any]]) -> None:
    for n, lap in enumerate(laps):
        lap["trial"] = 40 + n


def lower_cased(laps: list[dict[str, Any]]) -> None:
    for lap in laps:
        lap["status"] = lap["status"].lower()


def shifted(laps: list[dict[str, Any]]) -> None:
    for lap in laps:
        lap["started_ms"] += 7_777
        lap["ended_ms"] += 7_777


def dropped(laps: list[dict[str, Any]]) -> None:
    for lap in laps:
        lap["started_ms"] = lap["ended_ms"] = None


def one_ms_slower(laps: list[dict[str, Any]]) -> None:
    laps[2]["time_ms"] += 1
    laps[2]["ended_ms"] += 1


def extra_incomplete_lap(laps: list[dict[str, Any]]) -> None:
    laps.append({"trial": 99, "time_ms": 3_000, "completion_pct": 21.0, "status": "Off track"})


def reversed_laps(laps: list[dict[str, Any]]) -> None:
    laps.reverse()


def a_few_ms_off(laps: list[dict[str, Any]]) -> None:
    for n, lap in enumerate(laps):
        lap["time_ms"] += (-1) ** n * 3


# ---- 1. copies: what scores, not what it says ------------------------------------------------


@pytest.mark.parametrize("edit", [renumbered, lower_cased, shifted, dropped])
def test_a_cosmetic_edit_of_the_leaders_run_is_still_a_copy(
        service: LeaderboardService, edit: Callable[[list[dict[str, Any]]], None]) -> None:
    service.push(leader(), caller=BLAZE)
    copy = edited(leader(), "Copycat", edit)
    with pytest.raises(CopiedRun, match="'blaze'"):
        service.push(copy, caller=COPIER)
    assert [e.racer for e in service.board_page(TRACK).entries] == ["Blaze"]


@pytest.mark.parametrize("edit", [one_ms_slower, extra_incomplete_lap, reversed_laps, a_few_ms_off])
def test_a_near_copy_of_the_leaders_run_is_flagged_for_the_organiser(
        service: LeaderboardService, edit: Callable[[list[dict[str, Any]]], None]) -> None:
    service.push(leader(), caller=BLAZE)
    receipt = service.push(edited(leader(), "Copycat", edit), caller=COPIER)
    assert isinstance(receipt, PushReceipt)
    assert "near-copy" in receipt.entry.flags
    assert "near-copy" not in service.racer(TRACK, "Blaze").entry.flags
    flagged = [e for e in service.audit(TRACK).events if e.action == "flag"]
    assert flagged and "'blaze'" in flagged[0].detail and flagged[0].racer == "Copycat"


def test_two_racers_who_drove_one_lap_in_the_same_time_are_not_copies(
        service: LeaderboardService) -> None:
    service.push(make_record("Ada", [(9000, 100)]), caller=BLAZE)
    service.push(make_record("Bob", [(9000, 100)]), caller=COPIER)
    assert [(e.rank, e.racer, e.flags) for e in service.board_page(TRACK).entries] == [
        (1, "Ada", []), (1, "Bob", [])]


def test_a_copy_pushed_first_to_another_board_does_not_lock_its_author_out(
        service: LeaderboardService) -> None:
    service.push(leader(), caller=BLAZE)
    service.create_board(BoardSpec(board_id="club-final", title="Final", track="reInvent2019"))
    with pytest.raises(CopiedRun):
        service.push(edited(leader(), "Copycat", renumbered), "club-final", caller=COPIER)
    receipt = service.push(leader(), "club-final", caller=BLAZE)
    assert isinstance(receipt, PushReceipt) and receipt.status == "created" and receipt.rank == 1


def test_the_author_takes_their_run_back_from_a_copy_stored_before_the_rule(
        service: LeaderboardService, store: BoardStore) -> None:
    """A board from before: the copy holds the laps on club-final (written as the old code did),
    the author's own run is on the track's board, earlier. A recheck indexes both; the author's
    push to club-final is taken and the copy flagged."""
    service.push(leader(), caller=BLAZE)
    service.create_board(BoardSpec(board_id="club-final", title="Final", track="reInvent2019"))
    final = store.get_board("club-final")
    assert final is not None
    copy = edited(leader(), "Copycat", lambda laps: None)
    submission, entry = scored_write(copy, final.board, datetime(2026, 3, 2, tzinfo=UTC))
    store.record_submission(submission, copy.model_dump_json(), entry,
                            fingerprints=evaluation_fingerprints(copy))
    for board_id in ("club-final", TRACK):
        assert service.recheck_page(board_id).next_cursor is None
    receipt = service.push(leader(), "club-final", caller=BLAZE)
    assert isinstance(receipt, PushReceipt) and receipt.status == "created"
    copycat = store.get_entry("club-final", "copycat")
    assert copycat is not None and "copied-run" in copycat.score.flags


def test_a_racers_first_push_of_a_run_stays_first_when_they_push_it_to_another_board(
        service: LeaderboardService) -> None:
    service.push(leader(), caller=BLAZE)
    service.create_board(BoardSpec(board_id="club-final", title="Final", track="reInvent2019"))
    service.push(leader(), "club-final", caller=BLAZE)
    with pytest.raises(CopiedRun, match=f"already on {TRACK!r} under another racer"):
        service.push(edited(leader(), "Copycat", renumbered), "club-final", caller=COPIER)


def test_every_run_of_a_record_is_guarded_however_many_it_holds(service: LeaderboardService) -> None:
    """A record of the most runs a record may hold: its last run is claimed and compared like a
    record's only one (on DynamoDB its index does not fit the push's transaction)."""
    runs = [[(9000 + 10 * n + lap, 100) for lap in range(3)] for n in range(MAX_EVALUATION_RUNS)]
    service.push(make_record("Blaze", runs=runs), caller=BLAZE)
    with pytest.raises(CopiedRun, match="'blaze'"):
        service.push(make_record("Copycat", runs[-1]), caller=COPIER)
    near = make_record("Nearby", [(time + 2, pct) for time, pct in runs[-1]])
    receipt = service.push(near, caller=STRANGER)
    assert isinstance(receipt, PushReceipt) and receipt.entry.flags == ["near-copy"]


def test_an_imported_run_is_claimed_and_cannot_be_copied(service: LeaderboardService) -> None:
    service.create_board(BoardSpec(board_id="club-final", title="Final", track="reInvent2019"))
    service.import_submission("club-final", ImportedSubmission(
        submitted_at=datetime(2026, 2, 1, tzinfo=UTC), record=leader("Veteran")))
    with pytest.raises(CopiedRun, match="'veteran'"):
        service.push(edited(leader("Veteran"), "Impostor", renumbered), caller=COPIER)


def test_a_recheck_fills_in_the_fingerprints_of_an_existing_board(
        service: LeaderboardService, store: BoardStore) -> None:
    """Runs stored before the index (written as the old code wrote them) are claimed by the
    recheck, on SQLite and DynamoDB alike."""
    stored = store.create_board(Board(board_id=TRACK, track=TRACK, title="Smile Speedway",
                                      created_at=datetime(2026, 1, 1, tzinfo=UTC)))
    old = leader()
    submission, entry = scored_write(old, stored.board, datetime(2026, 1, 2, tzinfo=UTC))
    store.record_submission(submission, old.model_dump_json(), entry)
    service.push(edited(leader(), "Early", renumbered), caller=COPIER)  # slips through: no index
    page = service.recheck_page(TRACK)
    assert [(f.racer, f.flag) for f in page.flagged] == [("Early", "copied-run")]
    with pytest.raises(CopiedRun):
        service.push(edited(leader(), "Late", renumbered), caller=STRANGER)
    assert service.recheck_page(TRACK).flagged == [], "a second recheck flags nothing new"


# ---- 2. aliases that cannot be taken ------------------------------------------------------------


def test_an_alias_with_results_but_no_sign_in_cannot_be_taken(service: LeaderboardService) -> None:
    service.push(make_record("Veteran", [(9500, 100)]), caller=ORGANISER)  # before sign-ins
    with pytest.raises(AliasTaken, match="only an organiser"):
        service.push(make_record("Veteran", [(9400, 100)], model="impostor-model"), caller=STRANGER)
    with pytest.raises(AliasTaken, match="only an organiser"):
        service.claim_alias("veteran", caller=STRANGER)
    assert [item.model_name for item in service.history("Veteran")] == ["m1"]


def test_a_refused_push_claims_nothing(service: LeaderboardService) -> None:
    service.create_board(BoardSpec(board_id="closed", title="Closed", track="reInvent2019",
                                   closes_at=datetime(2026, 1, 1, tzinfo=UTC)))
    with pytest.raises(BoardClosed):
        service.push(make_record("Famous", [(9500, 100)]), "closed", caller=STRANGER)
    assert service.me(STRANGER).alias is None
    service.push(make_record("Famous", [(9500, 100)]), caller=BLAZE)
    assert service.me(BLAZE).alias == "Famous"


def test_organisers_reserve_give_and_release_aliases_with_an_audit(
        service: LeaderboardService) -> None:
    for alias in ("Famous", "Ada", "Blaze"):
        service.assign_alias(alias, caller=ORGANISER)
    with pytest.raises(AliasTaken, match="kept by the board's organiser"):
        service.claim_alias("famous", caller=STRANGER)
    with pytest.raises(AliasTaken):
        service.push(make_record("Famous", [(9500, 100)]), caller=STRANGER)
    service.assign_alias("Famous", BLAZE.principal, caller=ORGANISER)
    service.push(make_record("Famous", [(9500, 100)]), caller=BLAZE)
    with pytest.raises(AliasTaken, match="replace"):
        service.assign_alias("Famous", STRANGER.principal, caller=ORGANISER)
    service.assign_alias("Famous", STRANGER.principal, replace=True, caller=ORGANISER)
    assert service.me(STRANGER).alias == "Famous" and service.me(BLAZE).alias is None
    service.release_alias("famous", caller=ORGANISER)
    assert service.me(STRANGER).alias is None
    listed = {view.alias: view.reserved for view in service.aliases().aliases}
    assert listed == {"Ada": True, "Blaze": True}
    trail = [(e.action, e.racer, e.actor) for e in service.alias_audit().events]
    assert trail == [("alias-reserve", "Famous", ORGANISER.principal),
                     ("alias-reserve", "Ada", ORGANISER.principal),
                     ("alias-reserve", "Blaze", ORGANISER.principal),
                     ("alias-assign", "Famous", ORGANISER.principal),
                     ("alias-assign", "Famous", ORGANISER.principal),
                     ("alias-release", "Famous", ORGANISER.principal)]


def test_a_seasons_racers_are_reserved_in_one_command(tmp_path: Path) -> None:
    db = str(tmp_path / "board.db")
    result = CliRunner().invoke(cli, ["--db", db, "aliases", "reserve", "Ada", "Blaze", "Indy"])
    assert result.exit_code == 0, result.output
    listed = json.loads(CliRunner().invoke(cli, ["--db", db, "aliases", "list", "--format",
                                                 "json"]).stdout)
    assert [(a["alias"], a["reserved"]) for a in listed] == [
        ("Ada", True), ("Blaze", True), ("Indy", True)]
    bad = CliRunner().invoke(cli, ["--db", db, "aliases", "reserve", "Zed", "Z\u200bed"])
    assert bad.exit_code == 2 and "invisible" in bad.stderr


@pytest.fixture
def pool(aws: None) -> tuple[Any, str]:
    cognito = boto3.client("cognito-idp", region_name=REGION)
    return cognito, cognito.create_user_pool(PoolName="racers")["UserPool"]["Id"]


def test_invite_creates_the_users_and_gives_them_their_aliases_once(
        pool: tuple[Any, str], tmp_path: Path) -> None:
    cognito, pool_id = pool
    service = LeaderboardService(SqliteStore(tmp_path / "board.db"), clock=Clock())
    listing = tmp_path / "racers.csv"
    listing.write_text("email,alias\nada@example.org,Ada\nblaze@example.org, Blaze \n")
    racers = invites.read_racers(str(listing), listing.open())
    first = invites.invite(racers, service, cognito, pool_id)
    assert [(r.user, r.alias) for r in first] == [("created", "theirs"), ("created", "theirs")]
    sub = next(a["Value"] for a in cognito.admin_get_user(
        UserPoolId=pool_id, Username="ada@example.org")["UserAttributes"] if a["Name"] == "sub")
    ada = Caller(principal=f"cognito:{sub}")
    assert service.me(ada).alias == "Ada"
    service.push(make_record("Ada", [(9000, 100)]), caller=ada)
    again = invites.invite(racers, service, cognito, pool_id)
    assert [(r.user, r.alias) for r in again] == [("existed", "theirs"), ("existed", "theirs")]
    assert len(cognito.list_users(UserPoolId=pool_id)["Users"]) == 2


def test_invite_checks_every_line_before_inviting_anyone(tmp_path: Path) -> None:
    listing = tmp_path / "racers.csv"
    listing.write_text("ada@example.org,Ada\nnot-an-email,Bob\n")
    result = CliRunner().invoke(cli, ["--endpoint", "http://127.0.0.1:9", "invite", str(listing)])
    assert result.exit_code == 2 and "racers.csv:2: email" in result.stderr


# ---- 3. one identity rule for names ---------------------------------------------------------------

INVISIBLE_SPELLINGS = ["Bl\u034faze", "Blaze\ufe0f", "\u3164Blaze", "Blaze\u2800", "Bla\u00adze",
                       "Bla\u200bze", "Bla\u2060ze", "\u202eezalB", "Bla\u3000ze", "Bla\U000e0020ze",
                       "Bla\u115fze"]
MIXED_SPELLINGS = ["Bl\u0430ze", "\ua4d5laze", "\u0392laze", "Bla\u0437e"]


@pytest.mark.parametrize("spelling", INVISIBLE_SPELLINGS + MIXED_SPELLINGS, ids=ascii)
def test_an_alias_that_could_pass_for_another_is_refused(spelling: str) -> None:
    with pytest.raises(ValueError, match=r"invisible|not written together"):
        make_record(spelling, [(9000, 100)])


@pytest.mark.parametrize(("existing", "lookalike"), [
    ("ACE", "\u0410\u0421\u0415"), ("ABE", "\u0391\u0392\u0395"),
    ("ACE", "\ua4ee\ua4da\ua4f0"), ("Blaze", "BIaze"), ("Ollie", "0llie")], ids=ascii)
def test_a_whole_script_lookalike_of_a_racer_on_the_board_is_refused(
        service: LeaderboardService, existing: str, lookalike: str) -> None:
    service.push(make_record(existing, [(9000, 100)]), caller=BLAZE)
    with pytest.raises(AliasTaken, match="could pass for"):
        service.push(make_record(lookalike, [(9100, 100)]), caller=STRANGER)
    assert service.me(STRANGER).alias is None


def test_names_of_one_script_and_of_scripts_written_together_are_fine() -> None:
    for alias in ("Zoë", "Ζωή", "Жанна", "田中Taro", "たなか", "김민준", "Ada 2"):
        assert make_record(alias, [(9000, 100)]).racer == alias


@pytest.mark.parametrize("where", ["model_name", "sensor", "network", "hyperparameter key",
                                   "hyperparameter value", "lap status"])
@pytest.mark.parametrize("hostile", ["a\x1b]0;pwned\x07", "a\x9bb", "a\u202eb"], ids=ascii)
def test_every_design_string_is_printable_text(where: str, hostile: str) -> None:
    fields = make_record("Ada", [(9000, 100)]).model_dump(exclude={"submission_id"})
    design = fields["design"]
    if where == "model_name":
        fields["model_name"] = hostile
    elif where == "sensor":
        design["sensors"] = [hostile]
    elif where == "network":
        design["neural_network"] = hostile
    elif where == "hyperparameter key":
        design["hyperparameters"]["other"] = {hostile: 1}
    elif where == "hyperparameter value":
        design["hyperparameters"]["other"] = {"x": hostile}
    else:
        fields["evaluations"][0]["laps"][0]["status"] = hostile
    with pytest.raises(ValueError, match=r"control or invisible character|should match pattern"):
        Record.build(**fields)


@pytest.mark.parametrize("track", ["custom.\x1b]0;pwned\x07", "a/b", "<script>x", "a b"], ids=ascii)
def test_a_custom_tracks_name_is_one_a_board_id_can_hold(track: str) -> None:
    with pytest.raises(ValueError, match=r"custom track's name|control"):
        make_record("Ada", [(9000, 100)], track=track)


#: What older rules let through: ESC and BEL where no pattern held them (titles, lap statuses,
#: sensors), C1 controls and bidirectional overrides in names, and rich markup anywhere.
HOSTILE = "\x1b]0;pwned\x07\x1b[2J\u202eX\x9b1m[link=http://evil]x[/link][/]"
NAME = "\u202eX\x9b1m[link=http://evil]x[/link][/]"


def hostile_board(db: Path) -> None:
    """A board file holding what older rules let in: control characters and rich markup in the
    board's title, a racer's alias and model name, a sensor and a lap's status."""
    store = SqliteStore(db)
    board = store.create_board(Board(board_id=TRACK, track=TRACK, title="Final " + HOSTILE,
                                     created_at=datetime(2026, 1, 1, tzinfo=UTC))).board
    fields = make_record("Ada", [(9000, 100)]).model_dump()
    fields |= {"racer": "Ada" + NAME, "model_name": "m" + NAME}
    fields["evaluations"][0]["laps"][0]["status"] = "s" + HOSTILE[:20]
    fields["design"]["sensors"] = ["CAM\x1b]0;pwned\x07\x1b[2J"]
    record = Record.model_validate(fields, context={"stored": True})
    submission, entry = scored_write(record, board, datetime(2026, 1, 2, tzinfo=UTC))
    store.record_submission(submission, record.model_dump_json(), entry)
    store.close()


@pytest.mark.parametrize("command", [
    ["boards"], ["pull", "--track", "reInvent2019"], ["pull", "--track", "reInvent2019", "--format",
                                                      "json"],
    ["pull", "--track", "reInvent2019", "--format", "markdown"],
    ["show", "Ada" + NAME, "--track", "reInvent2019"], ["history", "--racer", "Ada" + NAME],
    ["status", "--racer", "Ada" + NAME], ["audit", TRACK]], ids=lambda c: " ".join(c[:2]))
def test_the_cli_never_prints_a_control_character_from_the_board(
        tmp_path: Path, command: list[str]) -> None:
    hostile_board(tmp_path / "board.db")
    result = CliRunner().invoke(cli, ["--db", str(tmp_path / "board.db"), *command])
    assert result.exit_code == 0, result.output
    shown = result.stdout
    assert not any(char in shown for char in "\x1b\x07\x9b\u202e"), repr(shown[:400])
    assert "http://evil" not in shown or "[link=http://evil]" in shown, "a name is not markup"
    if command[0] in ("pull", "show", "history"):
        assert "\\u202e" in shown, "the controls are shown, escaped"


def test_pull_csv_neutralises_cells_a_spreadsheet_would_run(tmp_path: Path) -> None:
    db = str(tmp_path / "board.db")
    store = SqliteStore(db)
    board = store.create_board(Board(board_id=TRACK, track=TRACK, title="Smile",
                                     created_at=datetime(2026, 1, 1, tzinfo=UTC))).board
    for n, (racer, model) in enumerate([('=HYPERLINK("http://evil","x")', "+1+1"),
                                        ("@SUM(1)", "-2+3"), ("\tTab", "\rCR")]):
        fields = make_record("Ada", [(9000 + n, 100)]).model_dump() | {"racer": racer,
                                                                      "model_name": model}
        record = Record.model_validate(fields, context={"stored": True})
        submission, entry = scored_write(record, board, datetime(2026, 1, 2, tzinfo=UTC))
        store.record_submission(submission, record.model_dump_json(), entry)
    store.close()
    result = CliRunner().invoke(cli, ["--db", db, "pull", "--track", "reInvent2019", "--format", "csv"])
    assert result.exit_code == 0
    import csv
    import io
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    for row in rows:
        for column in ("racer", "model_name"):
            assert not row[column].startswith(("=", "+", "-", "@", "\t", "\r")), row[column]
    assert rows[0]["racer"] == '\'=HYPERLINK("http://evil","x")' and rows[0]["time_s"] == "9.000"


# ---- 4. bans bind to the person, across the event ---------------------------------------------------


def test_a_banned_racer_cannot_come_back_under_another_alias_or_board(
        service: LeaderboardService) -> None:
    service.push(make_record("Mallory", [(9000, 100)]), caller=STRANGER)
    moderation = service.ban(TRACK, "mallory", caller=ORGANISER)
    assert moderation.everywhere and moderation.principal == STRANGER.principal
    with pytest.raises(Banned):
        service.push(make_record("Mallory", [(8900, 100)], model="m2"), caller=STRANGER)
    with pytest.raises(Banned):  # the track's clockwise board is the same event
        service.push(make_record("Mallory", [(8900, 100)], direction="cw"), caller=STRANGER)
    with pytest.raises((Banned, AliasTaken)):
        service.push(make_record("NotMallory", [(8800, 100)]), caller=STRANGER)
    with pytest.raises(Banned):  # a new sign-in's alias is free, but the banned alias is not
        service.push(make_record("Mallory", [(8800, 100)], model="m3"), caller=ORGANISER)
    service.unban(TRACK, "Mallory", caller=ORGANISER)
    service.push(make_record("Mallory", [(8900, 100)], direction="cw"), caller=STRANGER)


def test_a_ban_on_one_board_only_leaves_the_others_open(service: LeaderboardService) -> None:
    service.push(make_record("Mallory", [(9000, 100)]), caller=STRANGER)
    service.ban(TRACK, "Mallory", caller=ORGANISER, everywhere=False)
    with pytest.raises(Banned):
        service.push(make_record("Mallory", [(8900, 100)], model="m2"), caller=STRANGER)
    service.push(make_record("Mallory", [(8900, 100)], direction="cw"), caller=STRANGER)


# ---- 5. board rules checked where they are written ------------------------------------------------


class RuleChangesMidPush:
    """The store, with an organiser's change landing between a push's checks and its write."""

    def __init__(self, store: BoardStore, change: Callable[[], None]) -> None:
        self._store = store
        self._change: Callable[[], None] | None = change

    def __getattr__(self, name: str) -> Any:
        return getattr(self._store, name)

    def record_submission(self, *args: Any, **kwargs: Any) -> Any:
        if self._change is not None:
            change, self._change = self._change, None
            change()
        return self._store.record_submission(*args, **kwargs)


@pytest.mark.parametrize("everywhere", [True, False], ids=["event ban", "board ban"])
def test_a_ban_landing_during_a_push_stops_it(store: BoardStore, everywhere: bool) -> None:
    organiser = LeaderboardService(store, clock=Clock())
    organiser.push(make_record("Mallory", [(9500, 100)]), caller=STRANGER)
    racing = LeaderboardService(RuleChangesMidPush(  # type: ignore[arg-type]
        store, lambda: organiser.ban(TRACK, "Mallory", caller=ORGANISER, everywhere=everywhere)),
        clock=Clock())
    with pytest.raises(Banned):
        racing.push(make_record("Mallory", [(8000, 100)], model="faster"), caller=STRANGER)
    assert organiser.board_page(TRACK).entries == []
    assert [s.model_name for s in store.history("mallory")] == ["m1"]


def test_a_board_closing_during_a_push_stops_it(store: BoardStore) -> None:
    clock = Clock()
    organiser = LeaderboardService(store, clock=clock)
    organiser.create_board(BoardSpec(board_id="final", title="Final", track="reInvent2019"))
    racing = LeaderboardService(RuleChangesMidPush(  # type: ignore[arg-type]
        store, lambda: organiser.update_board("final", BoardChanges(
            closes_at=clock.now - timedelta(hours=1), opens_at=clock.now - timedelta(hours=2)),
            caller=ORGANISER)), clock=clock)
    with pytest.raises(BoardClosed):
        racing.push(make_record("Ada", [(9000, 100)]), "final", caller=BLAZE)
    assert store.history("ada") == []


# ---- 6. policy on the way in -------------------------------------------------------------------------


def test_a_tightened_rule_flags_old_entries_and_breaks_no_page(
        monkeypatch: pytest.MonkeyPatch) -> None:
    client = Client(build_app(push_router, pull_router, admin_router),
                    LeaderboardService(SqliteStore(":memory:")))
    assert client.push(make_record("Ada", [(9000, 100)]))["statusCode"] == 201
    monkeypatch.setattr(record_module, "PLAUSIBLE_SPEED_FACTOR", 0.5)  # 9 s is now too fast
    for path in (f"/boards/{TRACK}/racers/Ada", f"/boards/{TRACK}/racers/Ada/view", f"/boards/{TRACK}"):
        assert client.get(path)["statusCode"] == 200, path
    page = client.service.recheck_page(TRACK)
    assert [(f.racer, f.flag) for f in page.flagged] == [("Ada", "rule-changed")]
    assert "rule-changed" in client.service.racer(TRACK, "Ada").entry.flags


# ---- 7. answers that say what happened ----------------------------------------------------------------


@pytest.fixture
def cloud(aws: None) -> tuple[DynamoDbStore, Any]:
    db = boto3.client("dynamodb", region_name=REGION)
    s3 = boto3.client("s3", region_name=REGION)
    s3.create_bucket(Bucket="archive", CreateBucketConfiguration={"LocationConstraint": REGION})
    s3.put_bucket_versioning(Bucket="archive", VersioningConfiguration={"Status": "Enabled"})
    return DynamoDbStore(create_board_table(db, "boards"), client=db), s3


def test_a_write_that_committed_before_a_timeout_answers_what_was_stored(
        cloud: tuple[DynamoDbStore, Any], monkeypatch: pytest.MonkeyPatch) -> None:
    store, s3 = cloud
    service = LeaderboardService(store, clock=Clock(), archive=S3Archive("archive", client=s3))
    write = store.client.transact_write_items

    def committed_then_timed_out(**kwargs: Any) -> Any:
        write(**kwargs)
        raise ReadTimeoutError(endpoint_url="https://dynamodb.eu-west-1.amazonaws.com")

    monkeypatch.setattr(store.client, "transact_write_items", committed_then_timed_out)
    receipt = service.push(make_record("Ada", [(9000, 100)]), caller=BLAZE)
    assert isinstance(receipt, PushReceipt)
    assert (receipt.status, receipt.improved, receipt.rank) == ("created", True, 1)


@pytest.mark.parametrize("failing", ["front_page", "count_better"])
def test_a_stored_push_whose_rank_cannot_be_read_answers_202(
        cloud: tuple[DynamoDbStore, Any], monkeypatch: pytest.MonkeyPatch, failing: str) -> None:
    """The receipt's read (the board's first entries, and the count of those ahead of the racer
    when they are not all among them) fails after the run was stored: 202, with where to read it."""
    store, _ = cloud
    service = LeaderboardService(store, clock=Clock())
    client = Client(build_app(push_router, pull_router, admin_router), service)
    assert client.push(make_record("Blaze", [(8000, 100)]))["statusCode"] == 201

    def busy(*_: Any) -> int:
        raise StoreBusy("the board's table is busy", 1)

    monkeypatch.setattr(store, failing, busy)
    answer = client.push(make_record("Ada", [(9000, 100)]))
    assert answer["statusCode"] == 202, answer["body"]
    accepted = PushAccepted.model_validate_json(answer["body"])
    assert accepted.receipt == f"/boards/{TRACK}/racers/Ada"
    assert store.get_entry(TRACK, "ada") is not None


@pytest.mark.parametrize("code", ["ValidationException", "AccessDeniedException",
                                  "ResourceNotFoundException"])
def test_every_store_refusal_has_a_named_answer(
        cloud: tuple[DynamoDbStore, Any], monkeypatch: pytest.MonkeyPatch, code: str) -> None:
    store, _ = cloud
    client = Client(build_app(push_router, pull_router, admin_router),
                    LeaderboardService(store, clock=Clock()))

    def refused(**_: Any) -> None:
        raise ClientError({"Error": {"Code": code, "Message": "no"}}, "TransactWriteItems")

    monkeypatch.setattr(store.client, "transact_write_items", refused)
    answer = client.push(make_record("Ada", [(9000, 100)]))
    assert answer["statusCode"] == 502, answer["body"]
    body = json.loads(answer["body"])
    assert body["error"] == "StoreFailed" and code in body["message"]


def test_a_push_refused_by_the_cooldown_writes_no_archive(cloud: tuple[DynamoDbStore, Any]) -> None:
    store, s3 = cloud
    service = LeaderboardService(store, clock=Clock(), archive=S3Archive("archive", client=s3))
    service.create_board(BoardSpec(board_id="final", title="Final", track="reInvent2019",
                                   cooldown_s=1800))
    service.push(make_record("Ada", [(9000, 100)]), "final", caller=BLAZE)
    with pytest.raises(Exception, match="one submission every"):
        service.push(make_record("Ada", [(8900, 100)], model="m2"), "final", caller=BLAZE)
    assert s3.list_objects_v2(Bucket="archive")["KeyCount"] == 1


def test_a_retried_push_adds_no_archive_version(
        cloud: tuple[DynamoDbStore, Any], monkeypatch: pytest.MonkeyPatch) -> None:
    store, s3 = cloud
    service = LeaderboardService(store, clock=Clock(), archive=S3Archive("archive", client=s3))
    write = store.client.transact_write_items
    failures = iter([ClientError({"Error": {"Code": "ThrottlingException", "Message": "slow"}},
                                 "TransactWriteItems")])

    def throttled_once(**kwargs: Any) -> Any:
        failure = next(failures, None)
        if failure is not None:
            raise failure
        return write(**kwargs)

    monkeypatch.setattr(store.client, "transact_write_items", throttled_once)
    record = make_record("Ada", [(9000, 100)])
    with pytest.raises(StoreBusy):
        service.push(record, caller=BLAZE)
    service.push(record, caller=BLAZE)
    assert len(s3.list_object_versions(Bucket="archive")["Versions"]) == 1


# ---- 8. edges ---------------------------------------------------------------------------------------------


@pytest.fixture
def client() -> Client:
    return Client(build_app(push_router, pull_router, admin_router),
                  LeaderboardService(SqliteStore(":memory:")))


@pytest.mark.parametrize("body", ["[{}]", "[]", "7", '"record"', "null"])
def test_a_body_that_is_not_an_object_is_refused_as_a_body(client: Client, body: str) -> None:
    if body == "[{}]":
        body = f"[{make_record().model_dump_json()}]"
    answer = client.request("POST", f"/boards/{TRACK}/submissions", body=body)
    assert answer["statusCode"] == 422, answer["body"]
    assert json.loads(answer["body"])["error"] == "InvalidSubmission"


RACER_TOKEN = {"jwt": {"claims": {"sub": "racer-sub", "token_use": "access",
                                  "cognito:groups": "[racers]"}}}


@pytest.mark.parametrize(("method", "path", "body"), [
    ("POST", "/boards", '{"board_id": 7}'), ("PATCH", f"/boards/{TRACK}", '{"title": []}'),
    ("PUT", "/aliases/Ada", '{"principal": 5}'), ("GET", f"/boards/{TRACK}/audit?limit=0", None)])
def test_an_organiser_route_refuses_a_racer_before_it_reads_the_body(
        client: Client, method: str, path: str, body: str | None) -> None:
    path, _, query = path.partition("?")
    answer = client.request(method, path, body=body, authorizer=RACER_TOKEN,
                            query=dict([query.split("=")]) if query else None)
    assert answer["statusCode"] == 403, answer["body"]
    assert json.loads(answer["body"])["error"] == "NotAuthorized"
    assert json.loads(answer["body"])["detail"] == []


@pytest.mark.parametrize(("claim", "organiser"), [
    ("[organisers racers]", True), ("[racers organisers]", True), (["organisers"], True),
    ("[racers,organisers]", False), ("[organisers,racers]", False), ("[organisers-x]", False)])
def test_groups_are_read_from_the_claims_list_form(claim: Any, organiser: bool) -> None:
    event = {"requestContext": {"authorizer": {"jwt": {"claims": {
        "sub": "s", "token_use": "access", "cognito:groups": claim}}}}}
    caller = caller_from_event(event)
    assert caller is not None and caller.organiser is organiser


def test_the_racer_page_charts_the_run_its_score_comes_from(service: LeaderboardService) -> None:
    service.create_board(BoardSpec(board_id="avg", title="Average", track="reInvent2019",
                                   method=TimingMethod.AVG_LAP_TIME, min_laps=3))
    record = make_record("Ada", runs=[
        [(8000, 100), (12000, 100), (12500, 100)],   # the fastest lap: 8 s, an average of 10.8 s
        [(9000, 100), (9100, 100), (9200, 100)]])    # the best average: 9.1 s
    service.push(record, "avg", caller=BLAZE)
    view = service.racer("avg", "Ada")
    assert view.entry.time_ms == 9100
    assert view.scored_run is not None and view.scored_run.source == "metrics/evaluation/eval-2.json"
    assert record.best_run.source == "metrics/evaluation/eval-1.json", "not the fastest lap's run"


def test_a_board_rule_set_makes_no_flagged_run_move(service: LeaderboardService) -> None:
    """Flags for the organiser never move a run, even where flagged runs do not rank."""
    service.create_board(BoardSpec(board_id="strict", title="Strict", track="reInvent2019",
                                   flagged_runs="unranked"))
    service.push(leader(), "strict", caller=BLAZE)
    receipt = service.push(edited(leader(), "Copycat", one_ms_slower), "strict", caller=COPIER)
    assert isinstance(receipt, PushReceipt)
    assert receipt.entry.qualified and "near-copy" in receipt.entry.flags


def test_invalid_alias_claims_are_bad_input(service: LeaderboardService) -> None:
    with pytest.raises(InvalidQuery, match="invisible"):
        service.claim_alias("Ad\u200ba", caller=STRANGER)

