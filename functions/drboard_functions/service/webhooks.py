"""Organisers' webhooks: add, list, remove and test the chat webhooks of a board (and, once
seasons hold boards, of a season). What is announced, and how, is :mod:`..notify`'s."""

from __future__ import annotations

import secrets

from ..errors import InvalidQuery, WebhookNotFound
from ..identity import LOCAL_ORGANISER, Caller
from ..models.notices import (
    MAX_WEBHOOKS,
    Announcement,
    Delivery,
    Target,
    Webhook,
    WebhookList,
    WebhookSpec,
    WebhookView,
)
from ..notify import sending
from ..notify.events import podium
from ..notify.messages import words
from ..notify.notifier import Notifier
from .boards import BoardKeeper


class Webhooks:
    def __init__(self, keeper: BoardKeeper) -> None:
        self.keeper = keeper
        self.store = keeper.store
        #: How messages are posted (tests give a fake).
        self.post: sending.Post = sending.post

    def add_webhook(self, board_id: str, spec: WebhookSpec,
                    caller: Caller = LOCAL_ORGANISER) -> WebhookView:
        """Add a webhook to the board: its events are posted to it from now on."""
        target = self._board(board_id)
        if len(self.store.webhooks(target.key)) >= MAX_WEBHOOKS:
            raise InvalidQuery(f"{board_id!r} has {MAX_WEBHOOKS} webhooks, the most a board may "
                               "have: remove one first")
        webhook = Webhook(webhook_id=secrets.token_hex(4), target=target, kind=spec.kind,
                          url=spec.url, events=list(dict.fromkeys(spec.events)),
                          created_at=self.keeper.clock())
        self.store.put_webhook(webhook)
        view = webhook.view()
        self.keeper.audit(board_id, "webhook-add", caller,
                          detail=f"{view.kind} webhook {view.webhook_id} ({view.url})")
        return view

    def webhooks(self, board_id: str) -> WebhookList:
        """The board's webhooks, their URLs cut short, with how their last delivery went."""
        target = self._board(board_id)
        return WebhookList(target=target, webhooks=[w.view() for w in self.store.webhooks(target.key)])

    def remove_webhook(self, board_id: str, webhook_id: str,
                       caller: Caller = LOCAL_ORGANISER) -> WebhookView:
        target = self._board(board_id)
        removed = self.store.delete_webhook(target.key, webhook_id)
        if removed is None:
            raise WebhookNotFound(f"{board_id!r} has no webhook {webhook_id!r} "
                                  f"(see `drboard board webhook list {board_id}`)")
        self.keeper.audit(board_id, "webhook-remove", caller, detail=f"{removed.kind} webhook {webhook_id}")
        return removed.view()

    def test_webhook(self, board_id: str, webhook_id: str, board_url: str | None = None) -> Delivery:
        """Post a test message to the webhook now (the board's podium as it stands), and note
        how it went on it. ``board_url`` is the board's page (its path when the board has no
        address of its own, as the embedded board)."""
        from ..web import board_path

        stored = self.keeper.require(board_id)
        board_url = board_url or board_path(board_id)
        target = Target(target_id=board_id)
        webhook = next((w for w in self.store.webhooks(target.key) if w.webhook_id == webhook_id), None)
        if webhook is None:
            raise WebhookNotFound(f"{board_id!r} has no webhook {webhook_id!r}")
        now = self.keeper.clock()
        test = Announcement(event_id=f"{board_id}#test#{now.isoformat()}", kind="board-close",
                            target=target, board_id=board_id, board_title=stored.board.title,
                            url=board_url, at=now, podium=podium(self.store, board_id), test=True)
        notifier = Notifier(self.store, self.keeper.clock, lambda _: board_url, self.post)
        return notifier.test(webhook, test.model_copy(update={"text": words(test)}))

    def _board(self, board_id: str) -> Target:
        self.keeper.require(board_id)
        return Target(kind="board", target_id=board_id)
