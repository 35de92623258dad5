"""Who posts announcements, once per event and webhook.

:class:`Notifier` sends an announcement to each webhook of its targets that hears that kind of
event. Before posting it claims a marker for (event, webhook) in the store, conditionally; once
the post succeeds the marker says ``sent`` and no retry posts it again, and a failed post marks
it ``failed`` for the next try. A sender that dies between its claim and its post holds the
marker for ``LEASE_S``, after which a retry may claim it. Each delivery is noted on the webhook
(``last_sent_at``, or ``last_error`` and when), which the organiser sees in `drboard board
webhook list`.

:class:`NoticeWorker` is `drboard serve`'s: a thread that takes the entry changes the service
tells it (a push only puts one on a queue: it never waits on a chat service) and looks at the
boards' windows every ``WINDOW_CHECK_S``. In the cloud the NotifyFunction does the same from the
table's stream and a schedule (:mod:`drboard_functions.handlers.notify`).
"""

from __future__ import annotations

import queue
import sys
import threading
import time
from collections.abc import Callable
from datetime import datetime
from functools import partial
from typing import TYPE_CHECKING

from ..models.notices import Announcement, Delivery, EntryChange, Webhook
from ..stores.base import BoardStore
from . import sending
from .events import BoardUrl, entry_announcement, season_boards, targets_of, window_announcements
from .messages import payload

if TYPE_CHECKING:
    from ..service import LeaderboardService

LEASE_S = 120
WINDOW_CHECK_S = 30.0


class Notifier:
    def __init__(self, store: BoardStore, clock: Callable[[], datetime], board_url: BoardUrl,
                 post: sending.Post = sending.post) -> None:
        self.store = store
        self.clock = clock
        self.board_url = board_url
        self.post = post

    def entry_changed(self, change: EntryChange) -> list[str]:
        """Announce what the change says, if anything; the failures (empty: all sent)."""
        if not self.listened(change.board_id):
            return []  # no one listens: no announcement to build (four reads a push, saved)
        announcement = entry_announcement(self.store, change, self.board_url)
        return self.announce(announcement) if announcement else []

    def listened(self, board_id: str) -> bool:
        """Whether any webhook hears of the board (its own, or the event's)."""
        return any(self.store.webhooks(target.key) for target in targets_of(self.store, board_id))

    def check_windows(self) -> list[str]:
        """Announce the openings and closings not yet announced of the boards that have
        webhooks, or are rounds (or finals) of seasons that have; the failures."""
        now = self.clock()
        failures: list[str] = []
        boards: set[str] = set()
        for target in {hook.target for hook in self.store.all_webhooks()}:
            boards |= ({target.target_id} if target.kind == "board"
                       else set(season_boards(self.store, target.target_id)))
        for board_id in sorted(boards):
            stored = self.store.get_board(board_id)
            if stored is None or stored.board.deleted_at is not None:
                continue
            for announcement in window_announcements(self.store, stored.board, now, self.board_url):
                failures += self.announce(announcement)
        return failures

    def announce(self, announcement: Announcement) -> list[str]:
        failures = []
        for target in targets_of(self.store, announcement.board_id):
            for webhook in self.store.webhooks(target.key):
                # A webhook hears what happens from when it was added; the stream's times are
                # whole seconds (rounded down), so from the second it was added.
                if (announcement.kind not in webhook.events
                        or webhook.created_at.replace(microsecond=0) > announcement.at):
                    continue
                error = self._deliver(webhook, announcement)
                if error:
                    failures.append(f"{webhook.webhook_id}: {error}")
        return failures

    def _deliver(self, webhook: Webhook, announcement: Announcement) -> str | None:
        if not self.store.claim_notice(announcement.event_id, webhook.webhook_id, self.clock(), LEASE_S):
            return None  # sent already, or being sent
        error = self.send(webhook, announcement)
        self.store.finish_notice(announcement.event_id, webhook.webhook_id, sent=error is None)
        return error

    def send(self, webhook: Webhook, announcement: Announcement) -> str | None:
        """Post to one webhook now and note how it went on it; the error, or None."""
        try:
            self.post(webhook.url, payload(webhook.kind, announcement))
            error = None
        except sending.DeliveryFailed as failed:
            error = str(failed)
        self.store.note_delivery(webhook.target.key, webhook.webhook_id, self.clock(), error)
        return error

    def test(self, webhook: Webhook, announcement: Announcement) -> Delivery:
        error = self.send(webhook, announcement)
        stored = next((w for w in self.store.webhooks(webhook.target.key)
                       if w.webhook_id == webhook.webhook_id), webhook)
        return Delivery(webhook=stored.view(), sent=error is None, error=error)


class NoticeWorker:
    """`drboard serve`'s announcer: a background thread (see the module's docstring)."""

    def __init__(self, service: LeaderboardService, base_url: str,
                 post: sending.Post = sending.post, window_check_s: float = WINDOW_CHECK_S) -> None:
        from .. import web

        self.service = service
        self.notifier = Notifier(service.store, service.clock,
                                 lambda board_id: base_url + web.board_path(board_id), post)
        self.changes: queue.SimpleQueue[EntryChange | None] = queue.SimpleQueue()
        self.window_check_s = window_check_s
        self.thread = threading.Thread(target=self._run, name="drboard-announcements", daemon=True)

    def start(self) -> NoticeWorker:
        self.service.listen(self._heard)
        self.thread.start()
        return self

    def _heard(self, change: EntryChange) -> None:
        # Asked in the push's own thread: a change no webhook hears of wakes no one.
        if self.notifier.listened(change.board_id):
            self.changes.put(change)

    def stop(self) -> None:
        """Stop taking changes; announce those already taken, then end the thread."""
        self.service.listen(None)
        self.changes.put(None)
        self.thread.join(timeout=30)

    def _run(self) -> None:
        checked = -self.window_check_s
        while True:
            if time.monotonic() - checked >= self.window_check_s:
                self._quietly(self.notifier.check_windows)
                checked = time.monotonic()
            try:
                change = self.changes.get(timeout=self.window_check_s)
            except queue.Empty:
                continue
            if change is None:
                return
            self._quietly(partial(self.notifier.entry_changed, change))

    @staticmethod
    def _quietly(work: Callable[[], object]) -> None:
        # A failed delivery is noted on its webhook; nothing else an announcement meets (a busy
        # board file) may stop the worker, and so the announcements after it. Said by its kind
        # only: a message might hold a webhook's URL.
        try:
            work()
        except Exception as error:
            sys.stderr.write(f"announcements: skipped one ({type(error).__name__})\n")
