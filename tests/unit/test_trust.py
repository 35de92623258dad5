"""Trust on the board: the alias bound to its racer, copied runs, moderation and the audit trail."""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from drboard_functions.errors import (
    AliasTaken,
    Banned,
    CopiedRun,
    InvalidQuery,
    NotAuthorized,
    NotSignedIn,
    RacerNotFound,
)
from drboard_functions.identity import Caller
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import LapSpec, copy_of, make_record

TRACK = "reInvent2019_track"
ADA = Caller(principal="cognito:ada-sub", name="ada@example.org")
BOB = Caller(principal="cognito:bob-sub", name="bob@example.org")
ORGANISER = Caller(principal="iam:arn:aws:iam::1:user/org", name="org", organiser=True)


class Clock:
    def __init__(self) -> None:
        self.now = datetime(2026, 3, 1, 12, 0, tzinfo=UTC)

    def __call__(self) -> datetime:
        self.now += timedelta(seconds=1)
        return self.now


@pytest.fixture
def store(tmp_path: Path) -> Iterator[SqliteStore]:
    store = SqliteStore(tmp_path / "board.db")
    yield store
    store.close()


@pytest.fixture
def service(store: SqliteStore) -> LeaderboardService:
    return LeaderboardService(store, clock=Clock())


def lap(ms: int) -> list[LapSpec]:
    return [(ms, 100)]


def standings(service: LeaderboardService) -> list[tuple[int, str]]:
    return [(e.rank, e.racer) for e in service.board_page(TRACK).entries]


# ---- the alias belongs to its racer ----------------------------------------------------------


def test_a_racers_first_push_claims_their_alias(service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(9000)), caller=ADA)
    assert service.me(caller=ADA).alias == "Ada"


def test_a_racer_cannot_push_as_another_racer(service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(9000)), caller=ADA)
    with pytest.raises(AliasTaken, match="'ada' belongs to another racer"):
        service.push(make_record("ada", lap(8000)), caller=BOB)
    with pytest.raises(AliasTaken, match="you push as 'Ada'"):
        service.push(make_record("Bob", lap(8000)), caller=ADA)
    assert standings(service) == [(1, "Ada")]
    assert service.me(caller=BOB).alias is None, "a refused push claims nothing"


@pytest.mark.parametrize("lookalike", ["ＡＤＡ", " ada ", "ADA"])
def test_spellings_that_fold_to_the_same_alias_are_the_same_racer(
        service: LeaderboardService, lookalike: str) -> None:
    service.push(make_record("Ada", lap(9000)), caller=ADA)
    with pytest.raises(AliasTaken):
        service.claim_alias(lookalike, caller=BOB)


@pytest.mark.parametrize(("alias", "problem"), [
    ("A\u200bda", "ZERO WIDTH SPACE"),
    ("Ada\u202e", "RIGHT-TO-LEFT OVERRIDE"),
    ("\u0410da", "mixes Cyrillic and Latin letters"),
])
def test_invisible_and_lookalike_aliases_are_refused(service: LeaderboardService, alias: str,
                                                     problem: str) -> None:
    with pytest.raises(InvalidQuery, match=problem):
        service.claim_alias(alias, caller=BOB)
    assert service.me(caller=BOB).alias is None


def test_an_alias_is_claimed_once(service: LeaderboardService) -> None:
    assert service.claim_alias("Ada", caller=ADA).alias == "Ada"
    assert service.claim_alias("Ada", caller=ADA).alias == "Ada", "claiming it again changes nothing"
    with pytest.raises(AliasTaken, match="an alias is claimed once"):
        service.claim_alias("Ada Lovelace", caller=ADA)


def test_an_unsigned_push_is_refused_and_writes_nothing(service: LeaderboardService) -> None:
    with pytest.raises(NotSignedIn):
        service.push(make_record("Ada", lap(9000)), caller=None)
    assert service.boards() == []


def test_organisers_push_for_any_racer(service: LeaderboardService) -> None:
    service.claim_alias("Ada", caller=ADA)
    receipt = service.push(make_record("Ada", lap(9000)), caller=ORGANISER)
    assert receipt.status == "created"
    assert service.me(caller=ORGANISER).alias is None


# ---- copied runs -----------------------------------------------------------------------------


def test_the_leaders_run_renamed_and_rehashed_is_refused(service: LeaderboardService) -> None:
    leader = make_record("Ada", lap(9000))
    service.push(leader, caller=ADA)
    copied = copy_of(leader, "Bob")
    assert copied.submission_id != leader.submission_id
    with pytest.raises(CopiedRun, match="already on 'reInvent2019_track' under another racer"):
        service.push(copied, caller=BOB)
    assert standings(service) == [(1, "Ada")]
    assert service.history("Bob") == []


def test_a_racer_may_push_the_same_evaluation_with_another_model_name(
        service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(9000), model="first"), caller=ADA)
    receipt = service.push(make_record("Ada", lap(9000), model="renamed"), caller=ADA)
    assert receipt.status == "created"


# ---- moderation and audit ---------------------------------------------------------------------


def test_remove_entry_recomputes_the_standings_and_keeps_the_submissions(
        service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(9000)), caller=ADA)
    service.push(make_record("Bob", lap(9500)), caller=BOB)
    moderation = service.remove_entry(TRACK, "ada", caller=ORGANISER)
    assert moderation.entry_removed and moderation.board.participants == 1
    assert standings(service) == [(1, "Bob")]
    assert len(service.history("Ada")) == 1
    with pytest.raises(NotAuthorized, match="taken off"):
        service.push(make_record("Ada", lap(9000)), caller=ADA)
    service.push(make_record("Ada", lap(9900)), caller=ADA)
    assert standings(service) == [(1, "Bob"), (2, "Ada")], "a new run makes a new entry"


def test_a_banned_racer_is_refused_until_unbanned_and_gets_their_best_back(
        service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(9000)), caller=ADA)
    service.push(make_record("Ada", lap(9400), model="m2"), caller=ADA)
    service.push(make_record("Bob", lap(9500)), caller=BOB)
    assert service.ban(TRACK, "Ada", caller=ORGANISER).banned
    assert standings(service) == [(1, "Bob")]
    with pytest.raises(Banned):
        service.push(make_record("Ada", lap(8000), model="m3"), caller=ADA)
    unbanned = service.unban(TRACK, "Ada", caller=ORGANISER)
    assert not unbanned.banned and unbanned.board.participants == 2
    assert [(e.racer, e.time_ms) for e in service.board_page(TRACK).entries] == [
        ("Ada", 9000), ("Bob", 9500)]


def test_moderating_a_racer_who_never_pushed_is_racer_not_found(service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(9000)), caller=ADA)
    with pytest.raises(RacerNotFound):
        service.remove_entry(TRACK, "Nobody", caller=ORGANISER)


def test_the_audit_trail_says_who_did_what(service: LeaderboardService) -> None:
    service.push(make_record("Ada", lap(9000)), caller=ADA)
    service.push(make_record("Ada", lap(9000)), caller=ADA)  # a duplicate changes nothing
    service.push(make_record("Bob", lap(9500)), caller=BOB)
    service.ban(TRACK, "Bob", caller=ORGANISER)
    service.unban(TRACK, "Bob", caller=ORGANISER)
    events = service.audit(TRACK).events
    assert [(e.action, e.actor, e.racer) for e in events] == [
        ("push", ADA.principal, "Ada"), ("push", BOB.principal, "Bob"),
        ("ban", ORGANISER.principal, "Bob"), ("unban", ORGANISER.principal, "Bob")]
    assert events[0].submission_id is not None
    assert [e.at for e in events] == sorted(e.at for e in events)


def test_the_audit_trail_pages(service: LeaderboardService) -> None:
    for n in range(5):
        service.push(make_record("Ada", lap(9000 + n), model=f"m{n}"), caller=ADA)
    first = service.audit(TRACK, limit=3)
    assert len(first.events) == 3 and first.next_cursor
    rest = service.audit(TRACK, cursor=first.next_cursor, limit=3)
    assert len(rest.events) == 2 and rest.next_cursor is None
    with pytest.raises(InvalidQuery):
        service.audit(TRACK, cursor="../../etc")
