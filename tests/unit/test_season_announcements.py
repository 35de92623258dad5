"""A season's webhooks: they hear every round's board (and the final's) as the boards' own
webhooks do, each event once; the window check covers the season's boards; the routes and the
`drboard season webhook` commands, on fake chat endpoints served on this computer."""

from __future__ import annotations

import json
from collections.abc import Iterator
from datetime import timedelta
from pathlib import Path

import pytest
from click.testing import CliRunner
from drboard_cli.main import cli
from drboard_functions.models.notices import Target, WebhookSpec
from drboard_functions.models.requests import BoardSpec
from drboard_functions.models.seasons import SeasonSpec
from drboard_functions.notify.events import targets_of
from drboard_functions.routes import admin_router, build_app
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore

from tests.recordkit import make_record
from tests.unit.test_announcements import Clock, FakeChat, _changes, chat, chats, notifier, pushed
from tests.unit.test_routes import Client

__all__ = ["chats"]


@pytest.fixture
def service() -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    board = LeaderboardService(store, clock=Clock())
    for board_id, title in (("club-night", "Club night"), ("second-night", "Second night"),
                            ("other-night", "Other night")):
        board.create_board(BoardSpec(board_id=board_id, title=title, track="reInvent2019"))
    board.create_season(SeasonSpec(season_id="club-2027", title="Club season 2027"))
    board.add_round("club-2027", "club-night")
    board.add_round("club-2027", "second-night")
    yield board
    store.close()


def test_a_season_webhook_hears_each_round_and_no_other_board(service: LeaderboardService,
                                                              chats: list[FakeChat]) -> None:
    season_chat, night_chat = chat(chats), chat(chats)
    service.add_webhook("club-2027", WebhookSpec(kind="json", url=season_chat.url), kind="season")
    service.add_webhook("club-night", WebhookSpec(kind="json", url=night_chat.url))
    announce = notifier(service)
    assert targets_of(service.store, "club-night") == [
        Target(kind="board", target_id="club-night"), Target(kind="season", target_id="club-2027")]

    assert announce.entry_changed(pushed(service, "Ada", 9000)) == []
    service.push(make_record("Blaze", [(9100, 100)]), "second-night")
    entry = service.store.get_entry("second-night", "blaze")
    assert entry is not None
    from drboard_functions.models.notices import EntryChange

    announce.entry_changed(EntryChange(board_id="second-night", before=None, after=entry,
                                       at=entry.achieved_at))
    service.push(make_record("Comet", [(9200, 100)]), "other-night")
    other = service.store.get_entry("other-night", "comet")
    assert other is not None
    announce.entry_changed(EntryChange(board_id="other-night", before=None, after=other,
                                       at=other.achieved_at))

    heard = [body["text"] for body in season_chat.bodies]
    assert heard[0].startswith("🏆 Ada leads Club night")
    assert heard[1].startswith("🏆 Blaze leads Second night")
    assert len(heard) == 2, "not a board outside the season"
    assert [body["text"] for body in night_chat.bodies] == heard[:1], "the board's own hears its own"
    assert announce.entry_changed(pushed_again(service)) == [] and len(season_chat.bodies) == 2, \
        "each event once per webhook"


def pushed_again(service: LeaderboardService) -> object:
    from drboard_functions.models.notices import EntryChange

    entry = service.store.get_entry("club-night", "ada")
    assert entry is not None
    return EntryChange(board_id="club-night", before=None, after=entry, at=entry.achieved_at)


def test_the_window_check_covers_a_seasons_rounds_and_its_final(service: LeaderboardService,
                                                                chats: list[FakeChat]) -> None:
    endpoint = chat(chats)
    service.add_webhook("club-2027", WebhookSpec(kind="discord", url=endpoint.url,
                                                 events=["board-open", "board-close"]), kind="season")
    service.create_board(BoardSpec(board_id="club-final", title="Club final", track="reInvent2019"))
    from drboard_functions.models.seasons import FinalSpec

    service.set_final("club-2027", FinalSpec(board_id="club-final", top=8))
    announce = notifier(service)
    opens = service.clock() + timedelta(seconds=30)
    service.update_board("second-night", _changes(opens_at=opens))
    service.clock.now = opens + timedelta(seconds=5)  # type: ignore[attr-defined]
    service.push(make_record("Ada", [(9000, 100)]), "club-night")
    service.close_board("club-night")
    service.close_board("club-final")
    assert announce.check_windows() == []
    said = sorted(body["content"].split(" ", 2)[1] for body in endpoint.bodies)
    assert said == ["Club", "Club", "Second"], said
    assert any(body["content"].startswith("🟢 Second night is open") for body in endpoint.bodies)
    assert any(body["content"].startswith("🏁 Club night has closed. Podium: 🥇 Ada 9.000 s")
               for body in endpoint.bodies)
    assert any(body["content"].startswith("🏁 Club final has closed.") for body in endpoint.bodies)
    announce.check_windows()
    assert len(endpoint.bodies) == 3, "announced once"


def test_the_season_webhook_routes_add_list_test_and_remove(service: LeaderboardService,
                                                            chats: list[FakeChat]) -> None:
    endpoint = chat(chats)
    client = Client(build_app(admin_router), service)
    added = client.request("POST", "/seasons/club-2027/webhooks",
                           body=json.dumps({"kind": "slack", "url": endpoint.url}))
    assert added["statusCode"] == 201, added["body"]
    view = json.loads(added["body"])
    assert view["target"] == {"kind": "season", "target_id": "club-2027"}
    assert "s3cr3t" not in added["body"], "the URL is never answered in full"
    listed = json.loads(client.get("/seasons/club-2027/webhooks")["body"])
    assert [w["webhook_id"] for w in listed["webhooks"]] == [view["webhook_id"]]
    tested = client.request("POST", f"/seasons/club-2027/webhooks/{view['webhook_id']}/test")
    assert json.loads(tested["body"])["sent"] is True
    assert endpoint.bodies[-1]["text"].startswith(
        "🧪 A test from drboard: announcements of Club season 2027 come here.")
    assert client.get("/seasons/nowhere/webhooks")["statusCode"] == 404
    assert client.get("/boards/club-2027/webhooks")["statusCode"] == 404, "a season is not a board"
    removed = client.request("DELETE", f"/seasons/club-2027/webhooks/{view['webhook_id']}")
    assert removed["statusCode"] == 200
    again = client.request("DELETE", f"/seasons/club-2027/webhooks/{view['webhook_id']}")
    assert again["statusCode"] == 404 and json.loads(again["body"])["error"] == "WebhookNotFound"


def test_the_organiser_manages_a_seasons_webhooks_from_the_cli(tmp_path: Path,
                                                               chats: list[FakeChat]) -> None:
    endpoint = chat(chats)
    db = tmp_path / "board.db"
    store = SqliteStore(db)
    local = LeaderboardService(store)
    local.create_board(BoardSpec(board_id="club-night", title="Club night", track="reInvent2019"))
    local.create_season(SeasonSpec(season_id="club-2027", title="Club season 2027"))
    local.add_round("club-2027", "club-night")
    store.close()
    runner = CliRunner()
    added = runner.invoke(cli, ["--db", str(db), "season", "webhook", "add", "club-2027", "--kind", "json"],
                          input=endpoint.url + "\n")
    assert added.exit_code == 0, added.output
    assert "drboard season webhook test club-2027" in added.output and "s3cr3t" not in added.output
    webhook_id = added.output.split("webhook ")[1].split()[0]
    tested = runner.invoke(cli, ["--db", str(db), "season", "webhook", "test", "club-2027", webhook_id])
    assert tested.exit_code == 0, tested.output
    listed = runner.invoke(cli, ["--db", str(db), "season", "webhook", "list", "club-2027",
                                 "--format", "json"])
    assert json.loads(listed.output)["webhooks"][0]["last_sent_at"] is not None
    removed = runner.invoke(cli, ["--db", str(db), "season", "webhook", "remove", "club-2027", webhook_id])
    assert removed.exit_code == 0
    missing = runner.invoke(cli, ["--db", str(db), "season", "webhook", "list", "nowhere"])
    assert missing.exit_code == 1 and "nowhere" in missing.output
