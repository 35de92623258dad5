"""The organiser's and the racer's board commands on the embedded board, on a fixed clock:
`drboard board ...`, `boards`, `status`, `history` across boards, `export` and `import`."""

from __future__ import annotations

import json
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner, Result
from drboard_cli.board_options import parse_duration, parse_when
from drboard_cli.main import cli
from drboard_functions import display
from drboard_functions.service import LeaderboardService
from drboard_functions.service import transfer as transfer_module
from drboard_functions.stores.sqlite import SqliteStore

from tests.downloadkit import drfc_folder

EXAMPLES = sorted(p for p in (Path(__file__).parents[2] / "examples").iterdir() if p.is_dir())
COUNTER_CLOCKWISE = [p for p in EXAMPLES if not p.name.endswith("-cw")]
T0 = datetime(2026, 3, 1, 12, 0, tzinfo=UTC)


class Clock:
    """The board's time: fixed until a test moves it."""

    def __init__(self) -> None:
        self.now = T0

    def __call__(self) -> datetime:
        return self.now

    def advance(self, **delta: float) -> None:
        self.now += timedelta(**delta)


class Drboard:
    """Runs `drboard` against one embedded board file whose service reads the test's clock."""

    def __init__(self, db: Path, clock: Clock) -> None:
        self.db = db
        self.clock = clock
        self._stores: list[SqliteStore] = []

    def __call__(self, *args: str | Path, stdin: str | None = None) -> Result:
        command = ["--db", str(self.db), *map(str, args)]
        try:
            return CliRunner().invoke(cli, command, obj=self._open, input=stdin,
                                      catch_exceptions=False)
        finally:
            while self._stores:
                self._stores.pop().close()

    def ok(self, *args: str | Path, stdin: str | None = None) -> str:
        result = self(*args, stdin=stdin)
        assert result.exit_code == 0, result.stderr
        return result.stdout

    def json(self, *args: str | Path) -> Any:
        return json.loads(self.ok(*args, "--format", "json"))

    def boards(self) -> dict[str, dict[str, Any]]:
        return {board["board_id"]: board for board in self.json("boards")}

    def _open(self, db: Path) -> LeaderboardService:
        store = SqliteStore(db)
        self._stores.append(store)
        return LeaderboardService(store, clock=self.clock)


@pytest.fixture
def clock() -> Clock:
    return Clock()


@pytest.fixture
def drboard(tmp_path: Path, clock: Clock, monkeypatch: pytest.MonkeyPatch) -> Drboard:
    monkeypatch.setenv("COLUMNS", "160")  # tables as wide as a terminal window
    return Drboard(tmp_path / "board.db", clock)


@pytest.fixture
def other_board(tmp_path: Path, clock: Clock) -> Drboard:
    """A second, fresh embedded board: where an export is imported."""
    return Drboard(tmp_path / "other.db", clock)


def create_event(drboard: Drboard, *options: str, board_id: str = "event") -> None:
    drboard.ok("board", "create", board_id, "--title", "Club final", "--track", "reInvent2019",
               *options)


def push_as(drboard: Drboard, example: Path, racer: str = "Ada", board: str = "event") -> Result:
    return drboard("push", example, "--racer", racer, "--board", board)


# ---- WHEN and DURATION -----------------------------------------------------------------------


@pytest.mark.parametrize(("text", "seconds"), [
    ("90", 90), ("90s", 90), ("30m", 1800), ("1h30m", 5400), ("1h 30m", 5400), ("2d", 172_800),
    ("1d2h3m4s", 93_784), ("0", 0),
])
def test_durations_read_as_seconds(text: str, seconds: int) -> None:
    assert parse_duration(text) == seconds


@pytest.mark.parametrize("text", ["", "m", "30 minutes", "1.5h", "-5", "30m1h", "h"])
def test_a_bad_duration_says_how_to_write_one(text: str) -> None:
    with pytest.raises(ValueError, match="1h30m"):
        parse_duration(text)


@pytest.mark.parametrize(("text", "moment"), [
    ("2026-12-01T18:00:00Z", datetime(2026, 12, 1, 18, tzinfo=UTC)),
    ("2026-12-01 19:00+01:00", datetime(2026, 12, 1, 18, tzinfo=UTC)),
    ("now", T0),
    ("NOW", T0),
])
def test_moments_read_in_utc(text: str, moment: datetime) -> None:
    assert parse_when(text, now=lambda: T0) == moment


@pytest.mark.parametrize(("text", "says"), [
    ("2026-12-01T18:00", "no time zone"),
    ("tomorrow", "ISO 8601"),
    ("2026-13-01T18:00Z", "ISO 8601"),
])
def test_a_bad_moment_says_what_is_wrong(text: str, says: str) -> None:
    with pytest.raises(ValueError, match=says):
        parse_when(text)


@pytest.mark.parametrize(("seconds", "text"), [
    (0, "0 s"), (90, "1 min 30 s"), (5400, "1 h 30 min"), (7 * 86_400, "7 d"), (86_401, "1 d 1 s"),
])
def test_durations_read_for_people(seconds: int, text: str) -> None:
    assert display.duration(seconds) == text


def test_moments_read_for_people_in_utc() -> None:
    assert display.when(datetime(2026, 12, 1, 19, tzinfo=timezone(timedelta(hours=1)))) == (
        "2026-12-01 18:00 UTC")
    assert display.when(datetime(2026, 12, 1, 18, 0, 5, tzinfo=UTC)) == "2026-12-01 18:00:05 UTC"
    assert display.when(None) == display.DASH


# ---- board create --------------------------------------------------------------------------


def test_create_makes_a_named_board_with_its_rules_window_and_limits(drboard: Drboard) -> None:
    out = drboard.ok("board", "create", "event", "--title", "Club final", "--track", "Smile Speedway",
                     "--method", "avg_lap_time", "--opens-at", "2026-03-01T13:00:00+01:00",
                     "--closes-at", "2026-03-08T18:00Z", "--cooldown", "1h30m",
                     "--max-submissions", "5", "--description", "Bring your [best] model")
    assert "Club final" in out and "1 h 30 min" in out and "at most 5" in out
    assert "[best]" in out, "titles and descriptions are printed as they are, not as markup"
    board = drboard.boards()["event"]
    assert board | {"participants": 0} == board
    assert (board["kind"], board["track"], board["method"], board["min_laps"]) == (
        "named", "reInvent2019_track", "AVG_LAP_TIME", 3)
    assert (board["opens_at"], board["closes_at"]) == ("2026-03-01T12:00:00Z", "2026-03-08T18:00:00Z")
    assert (board["cooldown_s"], board["max_submissions"], board["status"]) == (5400, 5, "OPEN")


def test_create_takes_race_type_direction_and_custom_tracks(drboard: Drboard) -> None:
    drboard.ok("board", "create", "cw-event", "--title", "Clockwise", "--track", "reInvent2019",
               "--clockwise", "--min-laps", "2")
    drboard.ok("board", "create", "garage", "--title", "Garage", "--track", "my_garage_track",
               "--custom-track", "--race-type", "object_avoidance")
    boards = drboard.boards()
    assert (boards["cw-event"]["direction"], boards["cw-event"]["min_laps"]) == ("cw", 2)
    assert (boards["garage"]["track"], boards["garage"]["race_type"]) == (
        "my_garage_track", "OBJECT_AVOIDANCE")


@pytest.mark.parametrize(("options", "says"), [
    (["--opens-at", "next week"], "--opens-at"),
    (["--closes-at", "2026-03-08T18:00"], "no time zone"),
    (["--cooldown", "half an hour"], "--cooldown"),
    (["--cooldown", "8d"], "longest allowed, 7 d"),
    (["--max-submissions", "0"], "--max-submissions"),
    (["--max-submissions", "none"], "--max-submissions"),
    (["--min-laps", "101"], "--min-laps"),
    (["--opens-at", "2026-03-08T18:00Z", "--closes-at", "2026-03-01T18:00Z"], "after --opens-at"),
    (["--title", " "], "--title"),
    (["--method", "FASTEST"], "--method"),
])
def test_create_with_bad_options_names_the_option_and_creates_nothing(
        drboard: Drboard, options: list[str], says: str) -> None:
    result = drboard("board", "create", "event", "--track", "reInvent2019",
                     *(["--title", "Final"] if "--title" not in options else []), *options)
    assert result.exit_code == 2
    assert says in result.stderr
    assert drboard.boards() == {}


@pytest.mark.parametrize(("board_id", "track", "says"), [
    ("reInvent2019_track", "reInvent2019", "default board"),
    ("bad id!", "reInvent2019", "letters, digits"),
    ("event", "reInvnt2019", "reInvent2019"),
])
def test_create_refuses_bad_ids_and_unknown_tracks(drboard: Drboard, board_id: str, track: str,
                                                   says: str) -> None:
    result = drboard("board", "create", board_id, "--title", "Final", "--track", track)
    assert result.exit_code == 2
    assert says in result.stderr


def test_create_refuses_an_id_taken(drboard: Drboard) -> None:
    create_event(drboard)
    result = drboard("board", "create", "event", "--title", "Again", "--track", "reInvent2019")
    assert result.exit_code == 2
    assert "already" in result.stderr
    assert drboard.boards()["event"]["title"] == "Club final"


# ---- board update ---------------------------------------------------------------------------


def test_update_changes_only_the_options_given(drboard: Drboard) -> None:
    create_event(drboard, "--cooldown", "30m", "--max-submissions", "3",
                 "--closes-at", "2026-03-08T18:00Z", "--description", "Rules")
    out = drboard.ok("board", "update", "event", "--title", "Club final, day 2")
    assert "Club final, day 2" in out
    board = drboard.boards()["event"]
    assert (board["title"], board["description"], board["cooldown_s"], board["max_submissions"],
            board["closes_at"]) == ("Club final, day 2", "Rules", 1800, 3, "2026-03-08T18:00:00Z")


def test_update_none_clears_times_and_limits(drboard: Drboard) -> None:
    create_event(drboard, "--cooldown", "30m", "--max-submissions", "3",
                 "--opens-at", "2026-03-01T13:00Z", "--closes-at", "2026-03-08T18:00Z")
    drboard.ok("board", "update", "event", "--cooldown", "none", "--max-submissions", "none",
               "--opens-at", "none", "--closes-at", "NONE")
    board = drboard.boards()["event"]
    assert (board["cooldown_s"], board["max_submissions"], board["opens_at"], board["closes_at"]) == (
        0, None, None, None)
    assert board["status"] == "OPEN"


def test_update_refuses_bad_input(drboard: Drboard) -> None:
    create_event(drboard)
    nothing = drboard("board", "update", "event")
    assert nothing.exit_code == 2 and "at least one option" in nothing.stderr
    bad_time = drboard("board", "update", "event", "--closes-at", "soon")
    assert bad_time.exit_code == 2 and "--closes-at" in bad_time.stderr
    drboard.ok("push", EXAMPLES[0])
    default = drboard("board", "update", "reInvent2019_track", "--title", "Mine")
    assert default.exit_code == 2 and "default board" in default.stderr
    unknown = drboard("board", "update", "nosuch", "--title", "Mine")
    assert unknown.exit_code == 1 and "nosuch" in unknown.stderr


def test_the_timing_cannot_change_once_the_board_has_entries(drboard: Drboard) -> None:
    create_event(drboard)
    drboard.ok("board", "update", "event", "--method", "TOTAL_TIME")
    assert push_as(drboard, COUNTER_CLOCKWISE[0]).exit_code == 0
    result = drboard("board", "update", "event", "--method", "BEST_LAP_TIME")
    assert result.exit_code == 2
    assert "has entries" in result.stderr
    assert drboard.boards()["event"]["method"] == "TOTAL_TIME"


# ---- windows and limits as racers meet them ----------------------------------------------------


def test_an_upcoming_board_refuses_pushes_until_it_opens(drboard: Drboard, clock: Clock) -> None:
    create_event(drboard, "--opens-at", "2026-03-01T14:00Z")
    assert drboard.json("boards", "--status", "upcoming")[0]["board_id"] == "event"
    result = push_as(drboard, COUNTER_CLOCKWISE[0])
    assert result.exit_code == 1
    assert "not open yet" in result.stderr and "2026-03-01 14:00 UTC" in result.stderr
    clock.advance(hours=2)
    assert push_as(drboard, COUNTER_CLOCKWISE[0]).exit_code == 0


def test_a_closed_board_refuses_pushes_and_keeps_its_standings(drboard: Drboard, clock: Clock) -> None:
    create_event(drboard)
    drboard.ok("push", COUNTER_CLOCKWISE[0], "--board", "event")
    clock.advance(minutes=5)
    out = drboard.ok("board", "close", "event")
    assert "closed" in out
    result = push_as(drboard, COUNTER_CLOCKWISE[1])
    assert result.exit_code == 1
    assert "'event' is closed" in result.stderr
    assert [b["board_id"] for b in drboard.json("boards", "--status", "closed")] == ["event"]
    assert drboard.json("boards", "--status", "open") == []
    assert len(drboard.json("pull", "--board", "event")["entries"]) == 1


def test_a_cooldown_push_says_when_to_try_again(drboard: Drboard, clock: Clock) -> None:
    create_event(drboard, "--cooldown", "30m")
    assert push_as(drboard, COUNTER_CLOCKWISE[0]).exit_code == 0
    clock.advance(minutes=10)
    result = push_as(drboard, COUNTER_CLOCKWISE[1])
    assert result.exit_code == 1
    assert "Ada may submit again at 2026-03-01 12:30 UTC (in 20 min)" in result.stderr
    assert push_as(drboard, COUNTER_CLOCKWISE[0]).exit_code == 0, "a duplicate is always answered"
    assert push_as(drboard, COUNTER_CLOCKWISE[2], racer="Bob").exit_code == 0, "per racer"
    clock.advance(minutes=20)
    assert push_as(drboard, COUNTER_CLOCKWISE[1]).exit_code == 0


def test_a_racer_past_the_maximum_is_told_so(drboard: Drboard) -> None:
    create_event(drboard, "--max-submissions", "1")
    assert push_as(drboard, COUNTER_CLOCKWISE[0]).exit_code == 0
    result = push_as(drboard, COUNTER_CLOCKWISE[1])
    assert result.exit_code == 1
    assert "all 1 submissions" in result.stderr
    drboard.ok("board", "update", "event", "--max-submissions", "none")
    assert push_as(drboard, COUNTER_CLOCKWISE[1]).exit_code == 0


# ---- delete and restore --------------------------------------------------------------------


def test_delete_hides_a_board_and_restore_brings_it_back_whole(drboard: Drboard) -> None:
    create_event(drboard)
    for example in COUNTER_CLOCKWISE[:3]:
        drboard.ok("push", example, "--board", "event")
    standings = drboard.json("pull", "--board", "event")
    out = drboard.ok("board", "delete", "event")
    assert "drboard board restore event" in out
    assert "event" not in drboard.boards()
    gone = drboard("pull", "--board", "event")
    assert gone.exit_code == 1 and "restore" in gone.stderr
    pushed = push_as(drboard, COUNTER_CLOCKWISE[3])
    assert pushed.exit_code == 1
    out = drboard.ok("board", "restore", "event")
    assert "Club final" in out
    assert "event" in drboard.boards()
    restored = drboard.json("pull", "--board", "event")
    assert restored["board"].pop("version") > standings["board"].pop("version")
    assert restored == standings


def test_default_boards_cannot_be_deleted_and_unknown_ones_are_not_found(drboard: Drboard) -> None:
    drboard.ok("push", EXAMPLES[0])
    refused = drboard("board", "delete", "reInvent2019_track")
    assert refused.exit_code == 2
    for command in ("close", "delete", "restore"):
        result = drboard("board", command, "nosuch")
        assert result.exit_code == 1 and "nosuch" in result.stderr, command


# ---- boards, status, history -----------------------------------------------------------------


def test_boards_lists_status_track_method_and_window(drboard: Drboard,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    drboard.ok("push", EXAMPLES[0])
    create_event(drboard, "--closes-at", "2026-03-08T18:00Z")
    create_event(drboard, "--opens-at", "2026-04-01T09:00Z", board_id="spring")
    out = drboard.ok("boards")
    for text in ("event", "spring", "reInvent2019_track", "Smile Speedway", "best lap", "open",
                 "upcoming", "2026-03-08 18:00 UTC", "2026-04-01 09:00 UTC"):
        assert text in out, text
    assert [b["board_id"] for b in drboard.json("boards", "--status", "upcoming")] == ["spring"]
    assert "No closed boards" in drboard.ok("boards", "--status", "closed")
    monkeypatch.setenv("COLUMNS", "80")
    assert "reInvent2019_track" in drboard.ok("boards"), "a narrow terminal never cuts a board id"


def test_status_shows_each_board_the_racer_pushed_to(drboard: Drboard, clock: Clock) -> None:
    create_event(drboard, "--cooldown", "1h", "--max-submissions", "3")
    for example in COUNTER_CLOCKWISE[:3]:
        drboard.ok("push", example, "--board", "event")
    clock.advance(minutes=1)
    drboard.ok("push", COUNTER_CLOCKWISE[0])
    (latest_on_event,) = drboard.json("history", "--board", "event")
    summary = drboard.json("status")
    assert [b["board"]["board_id"] for b in summary["boards"]] == ["reInvent2019_track", "event"]
    event = summary["boards"][1]
    assert event["submissions"] == 1 and event["submissions_left"] == 2
    assert event["next_submission_at"] == "2026-03-01T13:00:00Z"
    assert event["latest"]["submission_id"] == latest_on_event["submission_id"]
    out = drboard.ok("status")
    for text in ("event", "reInvent2019_track", "1 of 3", "Mar 01 13:00 UTC", "now",
                 f"of {event['board']['participants']}"):
        assert text in out, text
    only = drboard.json("status", "--board", "event")
    assert [b["board"]["board_id"] for b in only["boards"]] == ["event"]


def test_status_says_when_a_racer_may_not_submit(drboard: Drboard, clock: Clock) -> None:
    create_event(drboard, "--max-submissions", "1")
    create_event(drboard, "--cooldown", "30m", board_id="cooldown")
    push_as(drboard, COUNTER_CLOCKWISE[0])
    clock.advance(seconds=10)
    push_as(drboard, COUNTER_CLOCKWISE[0], board="cooldown")
    out = drboard.ok("status")
    assert "none left" in out
    assert "Mar 01 12:31 UTC" in out, "12:30:10 rounds up: a push at 12:30 would be refused"
    drboard.ok("board", "close", "cooldown")
    assert "board closed" in drboard.ok("status", "--board", "cooldown")


def test_status_of_the_leader_and_of_others(drboard: Drboard) -> None:
    for example in COUNTER_CLOCKWISE:
        drboard.ok("push", example)
    entries = drboard.json("pull", "--track", "reInvent2019")["entries"]
    leader, second = entries[0], entries[1]
    assert "leader" in drboard.ok("status", "--racer", leader["racer"])
    status = drboard.json("status", "--racer", second["racer"], "--track", "reInvent2019")
    assert status["boards"][0]["entry"]["gap_ms"] == second["gap_ms"]
    assert f"+{second['gap_ms'] / 1000:.3f} s" in drboard.ok("status", "--racer", second["racer"])


def test_status_needs_a_racer_with_submissions(drboard: Drboard, monkeypatch: pytest.MonkeyPatch) -> None:
    nobody = drboard("status")
    assert nobody.exit_code == 2 and "--racer" in nobody.stderr
    drboard.ok("push", EXAMPLES[0])
    unknown = drboard("status", "--racer", "Nobody")
    assert unknown.exit_code == 1 and "Nobody" in unknown.stderr
    monkeypatch.setenv("DRBOARD_RACER", "Nobody Either")
    assert drboard("status").exit_code == 1


def test_history_covers_every_board_of_the_racer(drboard: Drboard, clock: Clock) -> None:
    create_event(drboard)
    drboard.ok("push", COUNTER_CLOCKWISE[0], "--racer", "Ada")
    clock.advance(minutes=1)
    drboard.ok("push", COUNTER_CLOCKWISE[1], "--racer", "Ada", "--board", "event")
    items = drboard.json("history")
    assert [item["board_id"] for item in items] == ["reInvent2019_track", "event"]
    assert all(item["is_best"] for item in items)
    out = drboard.ok("history")
    assert "reInvent2019_track" in out and "event" in out
    assert [i["board_id"] for i in drboard.json("history", "--board", "event")] == ["event"]


# ---- export and import -----------------------------------------------------------------------


def export_file(drboard: Drboard, tmp_path: Path, board: str = "reInvent2019_track") -> Path:
    target = tmp_path / f"{board}.jsonl"
    result = drboard("export", board, "-o", target)
    assert result.exit_code == 0, result.stderr
    return target


@pytest.fixture
def small_pages(monkeypatch: pytest.MonkeyPatch) -> None:
    """Export pages of two lines, so every export here takes several pages."""
    monkeypatch.setattr(transfer_module, "EXPORT_ENTRIES", 2)
    monkeypatch.setattr(transfer_module, "EXPORT_SUBMISSIONS", 2)


@pytest.fixture
def pushed(drboard: Drboard, clock: Clock) -> None:
    for example in COUNTER_CLOCKWISE:
        drboard.ok("push", example)
        clock.advance(minutes=1)
    drboard.ok("push", COUNTER_CLOCKWISE[0], "--model", "second-try")


@pytest.mark.usefixtures("small_pages", "pushed")
def test_export_writes_the_board_its_entries_and_every_submission(drboard: Drboard, tmp_path: Path) -> None:
    exported = export_file(drboard, tmp_path)
    assert not list(tmp_path.glob("*.partial"))
    lines = [json.loads(line) for line in exported.read_text().splitlines()]
    kinds = [line["kind"] for line in lines]
    racers = len(COUNTER_CLOCKWISE)
    assert kinds == ["board"] + ["entry"] * racers + ["submission"] * (racers + 1)
    assert lines[0]["format"] == "drboard-export/1"
    assert all("record" in line for line in lines if line["kind"] == "submission")
    result = drboard("export", "reInvent2019_track")
    assert result.stdout == export_file(drboard, tmp_path).read_text()
    assert "Exported reInvent2019_track: 6 entries, 7 submissions" in result.stderr


def test_export_of_an_unknown_board_writes_nothing(drboard: Drboard, tmp_path: Path) -> None:
    result = drboard("export", "nosuch", "-o", tmp_path / "out.jsonl")
    assert result.exit_code == 1 and "nosuch" in result.stderr
    assert list(tmp_path.glob("out.jsonl*")) == []


@pytest.mark.usefixtures("small_pages", "pushed")
def test_export_then_import_gives_the_same_standings(drboard: Drboard, other_board: Drboard,
                                                     tmp_path: Path) -> None:
    exported = export_file(drboard, tmp_path)
    out = other_board.ok("import", exported)
    racers = len(COUNTER_CLOCKWISE)
    assert f"{racers + 1} submissions imported, 0 already there" in out
    pull = ("pull", "--track", "reInvent2019", "--top", "100")
    imported, original = other_board.json(*pull), drboard.json(*pull)
    del imported["board"]["version"], original["board"]["version"]  # each board counts its own
    assert imported == original
    assert other_board.json("history", "--racer", "Blaze") == drboard.json("history", "--racer", "Blaze")


@pytest.mark.usefixtures("pushed")
def test_importing_twice_changes_nothing(drboard: Drboard, other_board: Drboard, tmp_path: Path) -> None:
    exported = export_file(drboard, tmp_path)
    other_board.ok("import", exported)
    before = other_board.json("pull", "--track", "reInvent2019")
    out = other_board.ok("import", exported)
    assert f"0 submissions imported, {len(COUNTER_CLOCKWISE) + 1} already there" in out
    assert other_board.json("pull", "--track", "reInvent2019") == before
    assert drboard.ok("import", exported).count("0 submissions imported") == 1, "into its own board"


#: Two runs 3 ms a lap apart: (racer, lap time).
NEAR_RUNS = [("Ada", 38100), ("Bob", 38103)]


@pytest.mark.parametrize("pushed", [NEAR_RUNS, NEAR_RUNS[::-1]], ids=["Ada first", "Bob first"])
def test_an_import_flags_the_near_copy_the_board_flagged(drboard: Drboard, other_board: Drboard,
                                                         clock: Clock, tmp_path: Path,
                                                         pushed: list[tuple[str, int]]) -> None:
    """Of two runs a few milliseconds apart, the one pushed later is the near-copy. An export
    lists its submissions by id, not by time (so one of the two orders lists the near-copy
    first), and a recheck reads them so too: both still flag the one pushed later."""
    for racer, lap_ms in pushed:
        drboard.ok("push", drfc_folder(tmp_path / racer, lap_ms), "--racer", racer)
        clock.advance(minutes=5)
    other_board.ok("import", export_file(drboard, tmp_path, "Spain_track"))
    drboard.ok("board", "recheck", "Spain_track")
    (first, _), (later, _) = pushed
    for board in (drboard, other_board):
        assert board.json("history", "--racer", first)[0]["flags"] == []
        assert board.json("history", "--racer", later)[0]["flags"] == ["near-copy"]


def test_a_named_board_moves_with_its_settings(drboard: Drboard, other_board: Drboard,
                                               tmp_path: Path) -> None:
    create_event(drboard, "--cooldown", "10m", "--max-submissions", "4", "--method", "TOTAL_TIME",
                 "--closes-at", "2026-03-08T18:00Z")
    drboard.ok("push", COUNTER_CLOCKWISE[0], "--board", "event")
    other_board.ok("import", export_file(drboard, tmp_path, "event"))
    assert other_board.boards()["event"] == drboard.boards()["event"]


@pytest.mark.usefixtures("pushed")
def test_import_from_stdin_under_another_id(drboard: Drboard, other_board: Drboard) -> None:
    exported = drboard.ok("export", "reInvent2019_track")
    out = other_board.ok("import", "-", "--board", "backup", stdin=exported)
    assert "backup (created)" in out
    copy = other_board.json("pull", "--board", "backup")
    original = drboard.json("pull", "--board", "reInvent2019_track")
    assert copy["entries"] == original["entries"]
    assert copy["board"]["kind"] == "named"


@pytest.mark.usefixtures("pushed")
@pytest.mark.parametrize(("good", "bad", "says"), [
    ('"submitted_at":"', '"submitted_at":"yesterday', "submission.submitted_at: Input should be"),
    ('"kind":"submission"', '"kind":"lap"', 'kind: must be "board", "entry" or "submission"'),
    ('"board_id":"reInvent2019_track"', '"board_id":"elsewhere"', "submission.board_id: 'elsewhere'"),
    ('"time_ms":', '"time_ms":-', "record.evaluations[0].laps[0].time_ms"),
    ("}", "", "line: not JSON"),
])
def test_a_corrupted_line_is_named_and_nothing_is_imported(
        drboard: Drboard, other_board: Drboard, tmp_path: Path, good: str, bad: str, says: str) -> None:
    exported = export_file(drboard, tmp_path)
    lines = exported.read_text().splitlines()
    bad_line = len(lines) - 1  # the second last line: a submission, after many good ones
    assert good in lines[bad_line - 1]
    if good == '"time_ms":':  # the record's own laps, not the submission's score
        head, record = lines[bad_line - 1].split('"record":', 1)
        lines[bad_line - 1] = head + '"record":' + record.replace(good, bad, 1)
    else:
        lines[bad_line - 1] = lines[bad_line - 1].replace(good, bad, 1)
    exported.write_text("\n".join(lines) + "\n")
    result = other_board("import", exported)
    assert result.exit_code == 2
    assert f"{exported}:{bad_line}: " in result.stderr and says in result.stderr
    assert other_board.json("boards") == []


@pytest.mark.parametrize(("content", "says"), [
    ("", "empty"),
    ('{"kind":"entry","entry":{}}\n', "entry.board_id"),
    ("\n\n", "empty"),
])
def test_import_refuses_files_that_are_no_export(other_board: Drboard, tmp_path: Path, content: str,
                                                 says: str) -> None:
    source = tmp_path / "export.jsonl"
    source.write_text(content)
    result = other_board("import", source)
    assert result.exit_code == 2
    assert says in result.stderr and str(source) in result.stderr


def test_import_needs_the_board_line_first(drboard: Drboard, other_board: Drboard,
                                           tmp_path: Path) -> None:
    drboard.ok("push", EXAMPLES[0])
    lines = export_file(drboard, tmp_path).read_text().splitlines()
    swapped = tmp_path / "swapped.jsonl"
    swapped.write_text("\n".join([lines[1], lines[0], *lines[2:]]) + "\n")
    result = other_board("import", swapped)
    assert result.exit_code == 2 and f"{swapped}:1: kind: the first line must be the board" in result.stderr
    doubled = tmp_path / "doubled.jsonl"
    doubled.write_text("\n".join([lines[0], *lines]) + "\n")
    result = other_board("import", doubled)
    assert result.exit_code == 2 and f"{doubled}:2: kind: a second board line" in result.stderr


def test_import_into_a_board_of_another_track_imports_nothing(drboard: Drboard, tmp_path: Path) -> None:
    drboard.ok("push", COUNTER_CLOCKWISE[0])
    drboard.ok("board", "create", "oval", "--title", "Oval", "--track", "Oval_track")
    result = drboard("import", export_file(drboard, tmp_path), "--board", "oval")
    assert result.exit_code == 2
    assert "'oval' already exists" in result.stderr and "--board NEW_ID" in result.stderr
    assert drboard.boards()["oval"]["participants"] == 0


def test_import_of_a_missing_file_is_bad_input(other_board: Drboard, tmp_path: Path) -> None:
    result = other_board("import", tmp_path / "missing.jsonl")
    assert result.exit_code == 2
    assert "missing.jsonl" in result.stderr


# ---- moderation and audit ----------------------------------------------------------------------


def test_an_organiser_removes_bans_and_unbans_a_racer_and_the_audit_says_so(
        drboard: Drboard, clock: Clock) -> None:
    create_event(drboard)
    clock.advance(minutes=1)
    push_as(drboard, COUNTER_CLOCKWISE[0], racer="Ada")
    clock.advance(minutes=1)
    push_as(drboard, COUNTER_CLOCKWISE[1], racer="Bob")
    clock.advance(minutes=1)
    assert "Took Ada off event" in drboard.ok("board", "remove-entry", "event", "ada")
    assert [e["racer"] for e in drboard.json("pull", "--board", "event")["entries"]] == ["Bob"]
    clock.advance(minutes=1)
    assert "Banned Bob from event" in drboard.ok("board", "ban", "event", "Bob", "--only-this-board")
    assert drboard.json("pull", "--board", "event")["entries"] == []
    refused = push_as(drboard, COUNTER_CLOCKWISE[2], racer="Bob")
    assert refused.exit_code == 1 and "'Bob' is banned from 'event'" in refused.stderr
    clock.advance(minutes=1)
    assert "Bob may push to event again" in drboard.ok("board", "unban", "event", "bob")
    assert [e["racer"] for e in drboard.json("pull", "--board", "event")["entries"]] == ["Bob"]
    trail = drboard.json("audit", "event")
    assert [(e["action"], e.get("racer")) for e in trail] == [
        ("create", None), ("push", "Ada"), ("push", "Bob"), ("remove-entry", "Ada"),
        ("ban", "Bob"), ("unban", "Bob")]
    assert {e["actor"] for e in trail} == {"local"}
    table = drboard.ok("audit", "event")
    assert "remove-entry" in table and "this computer" in table


def test_moderating_an_unknown_racer_fails_with_its_name(drboard: Drboard) -> None:
    create_event(drboard)
    result = drboard("board", "remove-entry", "event", "Nobody")
    assert result.exit_code == 1 and "'Nobody' has no submissions on 'event'" in result.stderr


def test_the_same_run_under_another_racer_is_refused_as_a_copy(drboard: Drboard) -> None:
    create_event(drboard)
    assert push_as(drboard, COUNTER_CLOCKWISE[0], racer="Ada").exit_code == 0
    copied = push_as(drboard, COUNTER_CLOCKWISE[0], racer="Mallory")
    assert copied.exit_code == 1
    assert "already on 'event' under another racer" in copied.stderr
    assert [e["racer"] for e in drboard.json("pull", "--board", "event")["entries"]] == ["Ada"]


def test_a_board_can_keep_flagged_runs_off_the_ranking(drboard: Drboard) -> None:
    out = drboard.ok("board", "create", "strict", "--title", "Strict", "--track", "reInvent2019",
                     "--flagged-runs", "unranked")
    assert "shown below the qualified racers, unranked" in out
    assert drboard.boards()["strict"]["flagged_runs"] == "unranked"
    relaxed = drboard.ok("board", "update", "strict", "--flagged-runs", "rank")
    assert "Flagged runs" in relaxed and "unranked" not in relaxed


# ---- compare and insights -----------------------------------------------------------------------


@pytest.mark.usefixtures("pushed")
def test_compare_shows_two_designs_and_marks_the_differences(drboard: Drboard) -> None:
    compared = drboard.json("compare", "Blaze", "indy", "--track", "reInvent2019")
    assert [r["racer"] for r in compared["racers"]] == ["Blaze", "Indy"]
    assert "algorithm" in compared["differences"] and "action_space" in compared["differences"]
    assert [r["facts"]["algorithm"] for r in compared["racers"]] == ["clipped_ppo", "sac"]
    table = drboard.ok("compare", "Blaze", "Indy", "--track", "reInvent2019")
    assert "Blaze (#1" in table and "Indy (#2" in table
    assert next(line for line in table.splitlines() if "algorithm" in line).lstrip("│ ").startswith("≠")


@pytest.mark.usefixtures("pushed")
def test_compare_needs_two_to_four_racers_on_the_board(drboard: Drboard) -> None:
    assert drboard("compare", "Blaze", "--track", "reInvent2019").exit_code == 2
    missing = drboard("compare", "Blaze", "Nobody", "--track", "reInvent2019")
    assert missing.exit_code == 1 and "Nobody" in missing.stderr


@pytest.mark.usefixtures("pushed")
def test_insights_set_the_fastest_models_against_the_field(drboard: Drboard) -> None:
    found = drboard.json("insights", "--track", "reInvent2019", "--top", "2")
    assert (found["top"], found["field"]) == (2, len(COUNTER_CLOCKWISE))
    facts = {fact["fact"]: fact for fact in found["facts"]}
    assert facts["max_speed"]["top"] == "4"  # Blaze and Indy both top out at 4 m/s
    assert [p["racer"] for p in found["points"] if p["top"]] == ["Blaze", "Indy"]
    table = drboard.ok("insights", "--track", "reInvent2019", "--top", "2")
    assert "Top 2" in table and "top speed (m/s)" in table


def test_a_board_that_keeps_designs_private_shows_times_only(drboard: Drboard) -> None:
    create_event(drboard, "--designs", "after-close")
    for example in COUNTER_CLOCKWISE[:2]:
        drboard.ok("push", example, "--board", "event")
    assert "private until the board closes" in drboard.ok("pull", "--board", "event")
    assert all(e["design"] is None for e in drboard.json("pull", "--board", "event")["entries"])
    refused = drboard("compare", "Blaze", "Comet", "--board", "event")
    assert refused.exit_code == 1 and "private until it closes" in refused.stderr
    drboard.ok("board", "update", "event", "--designs", "public")
    assert "PPO" in drboard.ok("pull", "--board", "event")
