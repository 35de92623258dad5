"""Announcements in the club's chat, posted to fake Discord, Slack and JSON endpoints served on
this computer: what each event says, that a failing webhook is retried, shown to the organiser
and never holds a push, that a retried event is not posted twice, and that the URL stays secret.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner
from drboard_cli.main import cli
from drboard_functions.models.notices import EntryChange, WebhookSpec
from drboard_functions.models.requests import BoardSpec
from drboard_functions.notify import sending
from drboard_functions.notify.notifier import NoticeWorker, Notifier
from drboard_functions.service import LeaderboardService
from drboard_functions.stores.sqlite import SqliteStore
from pydantic import ValidationError

from tests.recordkit import make_record

SHOTS = Path(__file__).parents[2] / "docs" / "screenshots"


class FakeChat:
    """A chat service's webhook on 127.0.0.1: records each body; ``failures`` answers that many
    requests with ``status`` first."""

    def __init__(self, failures: int = 0, status: int = 500) -> None:
        self.bodies: list[dict[str, Any]] = []
        self.raw: list[bytes] = []
        self.failures = failures
        self.status = status
        self.requests = 0
        chat = self

        class Handler(BaseHTTPRequestHandler):
            def do_POST(self) -> None:
                data = self.rfile.read(int(self.headers["Content-Length"]))
                chat.requests += 1
                if chat.failures:
                    chat.failures -= 1
                    self.send_response(chat.status)
                    if chat.status == 429:
                        self.send_header("Retry-After", "0")
                    self.end_headers()
                    return
                chat.raw.append(data)
                chat.bodies.append(json.loads(data))
                self.send_response(204)
                self.end_headers()

            def log_message(self, *args: Any) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.thread = threading.Thread(target=self.server.serve_forever, daemon=True)
        self.thread.start()

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.server.server_address[1]}/api/webhooks/123/s3cr3t-t0ken"

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()


@pytest.fixture
def chats() -> Iterator[list[FakeChat]]:
    made: list[FakeChat] = []
    yield made
    for chat in made:
        chat.close()


def chat(chats: list[FakeChat], **options: Any) -> FakeChat:
    made = FakeChat(**options)
    chats.append(made)
    return made


class Clock:
    def __init__(self) -> None:
        self.now = datetime(2026, 12, 1, 18, 0, tzinfo=UTC)

    def __call__(self) -> datetime:
        self.now += timedelta(seconds=1)
        return self.now


@pytest.fixture
def service() -> Iterator[LeaderboardService]:
    store = SqliteStore(":memory:")
    board = LeaderboardService(store, clock=Clock())
    board.create_board(BoardSpec(board_id="club-night", title="Club night", track="reInvent2019"))
    yield board
    store.close()


def no_wait(seconds: float) -> None:
    pass


def notifier(service: LeaderboardService, **options: Any) -> Notifier:
    post = options.pop("post", lambda url, body: sending.post(url, body, sleep=no_wait))
    return Notifier(service.store, service.clock, lambda b: f"https://board.example/boards/{b}/view", post)


def pushed(service: LeaderboardService, racer: str, ms: int, model: str = "m1") -> EntryChange:
    """Push a run and return the change it made, as the stream (or serve's hook) tells it."""
    changes: list[EntryChange] = []
    service.listen(changes.append)
    service.push(make_record(racer, [(ms, 100)], model=model), "club-night")
    service.listen(None)
    assert len(changes) <= 1
    return changes[0] if changes else None  # type: ignore[return-value]


def test_discord_slack_and_json_hear_a_new_leader_with_racer_model_time_gap_and_move(
        service: LeaderboardService, chats: list[FakeChat]) -> None:
    discord, slack, plain = chat(chats), chat(chats), chat(chats)
    for kind, endpoint in (("discord", discord), ("slack", slack), ("json", plain)):
        service.add_webhook("club-night", WebhookSpec(kind=kind, url=endpoint.url))
    announce = notifier(service)
    for racer, ms in (("Blaze", 9100), ("Comet", 9500), ("Drifter", 9900)):
        announce.entry_changed(pushed(service, racer, ms))
    for endpoint in (discord, slack, plain):
        endpoint.bodies.clear()

    assert announce.entry_changed(pushed(service, "Ada", 8900, model="ada-v7")) == []

    [d], [s], [j] = discord.bodies, slack.bodies, plain.bodies
    assert d["content"] == ("🏆 Ada leads Club night with ada\\-v7: 8.900 s, 0.200 s ahead of Blaze "
                            "(new at #1).\n<https://board.example/boards/club-night/view>")
    assert d["allowed_mentions"] == {"parse": []}, "no name pings anyone"
    assert s["text"] == ("🏆 Ada leads Club night with ada-v7: 8.900 s, 0.200 s ahead of Blaze "
                         "(new at #1). <https://board.example/boards/club-night/view|Club night>")
    assert j["event"] == "new-leader" and j["announcement"]["racer"] == "Ada"
    assert j["announcement"]["time_ms"] == 8900 and j["announcement"]["rank"] == 1
    # The README shows these bodies, exactly as the chat services receive them.
    assert discord.raw[-1] == (SHOTS / "discord-received.json").read_bytes()
    assert slack.raw[-1] == (SHOTS / "slack-received.json").read_bytes()


def test_each_event_says_what_happened(service: LeaderboardService, chats: list[FakeChat]) -> None:
    endpoint = chat(chats)
    service.add_webhook("club-night", WebhookSpec(kind="json", url=endpoint.url))
    announce = notifier(service)
    for racer, ms in (("Blaze", 9100), ("Comet", 9500), ("Drifter", 9900), ("Ember", 9950)):
        announce.entry_changed(pushed(service, racer, ms))
    texts = [b["text"] for b in endpoint.bodies]
    assert texts[0].startswith("🏆 Blaze leads Club night with m1: 9.100 s (new at #1).")
    assert texts[1].startswith("🥈 Comet enters the top 3 on Club night with m1: 9.500 s, +0.400 s "
                               "to the leader (new at #2).")
    assert texts[3].startswith("⏱ Ember is on Club night with m1: 9.950 s, +0.850 s to the leader "
                               "(new at #4).")

    announce.entry_changed(pushed(service, "Ember", 9400, model="m2"))
    assert endpoint.bodies[-1]["event"] == "top-3"
    assert "(#4 → #2)" in endpoint.bodies[-1]["text"], "the rank's move"
    announce.entry_changed(pushed(service, "Blaze", 9000, model="m3"))
    assert endpoint.bodies[-1]["text"].startswith(
        "⏱ Blaze improves to 9.000 s on Club night with m3: the leader (stays #1).")
    assert pushed(service, "Blaze", 9300, model="m4") is None, "a slower run changes no entry"


def test_a_board_opening_and_closing_with_its_podium(service: LeaderboardService,
                                                     chats: list[FakeChat]) -> None:
    endpoint = chat(chats)
    service.add_webhook("club-night", WebhookSpec(kind="discord", url=endpoint.url,
                                                  events=["board-open", "board-close"]))
    announce = notifier(service)
    opens = service.clock() + timedelta(seconds=30)
    service.update_board("club-night", _changes(opens_at=opens))
    assert announce.check_windows() == [] and endpoint.bodies == [], "not open yet"
    service.clock.now = opens + timedelta(seconds=5)  # type: ignore[attr-defined]
    announce.check_windows()
    assert endpoint.bodies[0]["content"].startswith("🟢 Club night is open: push your runs.")
    for racer, ms in (("Blaze", 9100), ("Ada", 8900), ("Comet", 9500), ("Drifter", 9900)):
        service.push(make_record(racer, [(ms, 100)]), "club-night")
    service.close_board("club-night")
    announce.check_windows()
    announce.check_windows()
    assert len(endpoint.bodies) == 2, "each opening and closing is announced once"
    assert endpoint.bodies[1]["content"].startswith(
        "🏁 Club night has closed. Podium: 🥇 Ada 8.900 s, 🥈 Blaze 9.100 s (+0.200 s), "
        "🥉 Comet 9.500 s (+0.600 s).")


def _changes(**fields: Any) -> Any:
    from drboard_functions.models.requests import BoardChanges

    return BoardChanges.model_validate(fields)


def test_a_failing_webhook_is_retried_then_shown_to_the_organiser_and_the_push_stands(
        service: LeaderboardService, chats: list[FakeChat]) -> None:
    flaky, broken = chat(chats, failures=2, status=503), chat(chats, failures=99, status=500)
    good = chat(chats)
    for endpoint in (flaky, broken, good):
        service.add_webhook("club-night", WebhookSpec(kind="slack", url=endpoint.url))
    announce = notifier(service)

    failures = announce.entry_changed(pushed(service, "Ada", 8900))

    assert len(flaky.bodies) == 1 and flaky.requests == 3, "retried after two 503s"
    assert broken.requests == sending.TRIES and len(failures) == 1
    assert len(good.bodies) == 1, "a failing webhook holds no other"
    shown = [w for w in service.webhooks("club-night").webhooks if w.last_error]
    assert len(shown) == 1
    assert shown[0].last_error == "the service answered 500 Internal Server Error (3 tries)"
    assert shown[0].last_error_at is not None
    assert service.board_page("club-night").entries[0].racer == "Ada", "the push stands"

    # The stream retries the record: only the webhook that failed is posted to again.
    broken.failures = 0
    assert announce.entry_changed(pushed_again(service, "Ada")) == []
    assert (len(flaky.bodies), len(broken.bodies), len(good.bodies)) == (1, 1, 1)
    assert not [w for w in service.webhooks("club-night").webhooks if w.last_error], \
        "a delivery that succeeds clears the error"


def pushed_again(service: LeaderboardService, racer: str) -> EntryChange:
    """The same change again, as a retried stream record carries it."""
    entry = service.store.get_entry("club-night", racer.lower())
    assert entry is not None
    return EntryChange(board_id="club-night", before=None, after=entry, at=entry.achieved_at)


def test_an_unreachable_or_refusing_webhook_says_why_without_its_url(
        service: LeaderboardService, chats: list[FakeChat]) -> None:
    gone = chat(chats, failures=1, status=404)
    service.add_webhook("club-night", WebhookSpec(kind="discord", url=gone.url))
    dead = gone.url.replace(str(gone.server.server_address[1]), "9")  # nothing listens there
    service.add_webhook("club-night", WebhookSpec(kind="json", url=dead))
    failures = notifier(service).entry_changed(pushed(service, "Ada", 8900))

    assert gone.requests == 1, "a 404 is final: the webhook was removed"
    errors = sorted(w.last_error or "" for w in service.webhooks("club-night").webhooks)
    assert errors == ["the service answered 404 Not Found",
                      "the service could not be reached: Connection refused (3 tries)"]
    assert not any("s3cr3t" in text or "127.0.0.1" in text for text in errors + failures)


def test_a_webhook_url_is_never_shown_back_in_full(service: LeaderboardService,
                                                   chats: list[FakeChat]) -> None:
    endpoint = chat(chats)
    view = service.add_webhook("club-night", WebhookSpec(kind="discord", url=endpoint.url))
    assert view.url == "http://127.0.0.1/…0ken"
    listed = service.webhooks("club-night").model_dump_json()
    audit = service.audit("club-night").model_dump_json()
    assert "s3cr3t" not in listed + audit
    with pytest.raises(ValidationError, match="https"):
        WebhookSpec(kind="slack", url="http://hooks.slack.com/services/T0/B0/x")


def test_serve_announces_in_the_background_and_a_push_never_waits(
        service: LeaderboardService, chats: list[FakeChat]) -> None:
    slow = chat(chats)
    service.add_webhook("club-night", WebhookSpec(kind="json", url=slow.url))
    release = threading.Event()

    def held_post(url: str, body: dict[str, Any]) -> None:
        release.wait(10)  # a chat service that hangs
        sending.post(url, body)

    worker = NoticeWorker(service, "http://192.0.2.1:8000", post=held_post).start()
    try:
        receipt = service.push(make_record("Ada", [(8900, 100)]), "club-night")
        assert receipt.rank == 1 and slow.bodies == [], "the push is answered while the post waits"
        release.set()
    finally:
        worker.stop()
    assert [b["event"] for b in slow.bodies] == ["new-leader"]
    assert slow.bodies[0]["text"].endswith("http://192.0.2.1:8000/boards/club-night/view")


def test_the_organiser_adds_lists_tests_and_removes_webhooks_from_the_cli(
        tmp_path: Path, chats: list[FakeChat]) -> None:
    db = tmp_path / "board.db"
    store = SqliteStore(db)
    LeaderboardService(store).create_board(BoardSpec(board_id="club", title="Club", track="reInvent2019"))
    store.close()
    endpoint, broken = chat(chats), chat(chats, failures=99, status=403)
    runner = CliRunner()

    added = runner.invoke(cli, ["--db", str(db), "board", "webhook", "add", "club", "--kind", "discord"],
                          input=endpoint.url + "\n")
    assert added.exit_code == 0, added.output
    assert "s3cr3t" not in added.output and "…0ken" in added.output
    webhook_id = added.output.split("webhook ")[1].split()[0]
    tested = runner.invoke(cli, ["--db", str(db), "board", "webhook", "test", "club", webhook_id])
    assert tested.exit_code == 0, tested.output
    assert endpoint.bodies[0]["content"].startswith("🧪 A test from drboard")

    bad = runner.invoke(cli, ["--db", str(db), "board", "webhook", "add", "club", "--kind", "slack",
                              "--url", broken.url, "--event", "new-leader"])
    bad_id = bad.output.split("webhook ")[1].split()[0]
    failed = runner.invoke(cli, ["--db", str(db), "board", "webhook", "test", "club", bad_id])
    assert failed.exit_code == 1 and "403" in failed.output
    listed = runner.invoke(cli, ["--db", str(db), "board", "webhook", "list", "club", "--format", "json"])
    hooks = json.loads(listed.output)["webhooks"]
    assert [h["last_error"] is not None for h in hooks] == [False, True]
    assert "s3cr3t" not in listed.output
    removed = runner.invoke(cli, ["--db", str(db), "board", "webhook", "remove", "club", bad_id])
    assert removed.exit_code == 0
    again = runner.invoke(cli, ["--db", str(db), "board", "webhook", "remove", "club", bad_id])
    assert again.exit_code == 1 and "no webhook" in again.output


def test_a_429_waits_as_retry_after_says(chats: list[FakeChat]) -> None:
    limited = chat(chats, failures=1, status=429)
    waits: list[float] = []
    sending.post(limited.url, {"content": "hi"}, sleep=waits.append)
    assert waits == [0.0] and len(limited.bodies) == 1
    time.sleep(0)
