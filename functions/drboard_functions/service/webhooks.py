"""Organisers' webhooks: add, list, remove and test the chat webhooks of a board, or of a season
(``kind="season"``: they hear its rounds' and its final's events). What is announced, and how,
is :mod:`..notify`'s. Changes to a board's webhooks go in its audit trail (a season has none)."""

from __future__ import annotations

import secrets

from ..errors import InvalidQuery, SeasonNotFound, WebhookNotFound
from ..identity import LOCAL_ORGANISER, Caller
from ..models.notices import (
    MAX_WEBHOOKS,
    Announcement,
    Delivery,
    Target,
    TargetKind,
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

    def add_webhook(self, target_id: str, spec: WebhookSpec, caller: Caller = LOCAL_ORGANISER,
                    kind: TargetKind = "board") -> WebhookView:
        """Add a webhook to the board (or season): its events are posted to it from now on."""
        target = self._target(kind, target_id)
        if len(self.store.webhooks(target.key)) >= MAX_WEBHOOKS:
            raise InvalidQuery(f"{target_id!r} has {MAX_WEBHOOKS} webhooks, the most a {kind} may "
                               "have: remove one first")
        webhook = Webhook(webhook_id=secrets.token_hex(4), target=target, kind=spec.kind,
                          url=spec.url, events=list(dict.fromkeys(spec.events)),
                          created_at=self.keeper.clock())
        self.store.put_webhook(webhook)
        view = webhook.view()
        if kind == "board":
            self.keeper.audit(target_id, "webhook-add", caller,
                              detail=f"{view.kind} webhook {view.webhook_id} ({view.url})")
        return view

    def webhooks(self, target_id: str, kind: TargetKind = "board") -> WebhookList:
        """The board's (or season's) webhooks, their URLs cut short, with how their last
        delivery went."""
        target = self._target(kind, target_id)
        return WebhookList(target=target, webhooks=[w.view() for w in self.store.webhooks(target.key)])

    def remove_webhook(self, target_id: str, webhook_id: str, caller: Caller = LOCAL_ORGANISER,
                       kind: TargetKind = "board") -> WebhookView:
        target = self._target(kind, target_id)
        removed = self.store.delete_webhook(target.key, webhook_id)
        if removed is None:
            raise WebhookNotFound(f"{target_id!r} has no webhook {webhook_id!r} "
                                  f"(see `drboard {kind} webhook list {target_id}`)")
        if kind == "board":
            self.keeper.audit(target_id, "webhook-remove", caller,
                              detail=f"{removed.kind} webhook {webhook_id}")
        return removed.view()

    def test_webhook(self, target_id: str, webhook_id: str, board_url: str | None = None,
                     kind: TargetKind = "board") -> Delivery:
        """Post a test message to the webhook now (a board's podium as it stands), and note how
        it went on it. ``board_url`` is the board's (or season's) page (its path when the board
        has no address of its own, as the embedded board)."""
        from ..web import board_path, season_path

        target = self._target(kind, target_id)
        board_url = board_url or (board_path(target_id) if kind == "board" else season_path(target_id))
        webhook = next((w for w in self.store.webhooks(target.key) if w.webhook_id == webhook_id), None)
        if webhook is None:
            raise WebhookNotFound(f"{target_id!r} has no webhook {webhook_id!r}")
        now = self.keeper.clock()
        test = Announcement(event_id=f"{target.key}#test#{now.isoformat()}", kind="board-close",
                            target=target, board_id=target_id, board_title=self._title(target),
                            url=board_url, at=now, test=True,
                            podium=podium(self.store, target_id) if kind == "board" else [])
        notifier = Notifier(self.store, self.keeper.clock, lambda _: board_url, self.post)
        return notifier.test(webhook, test.model_copy(update={"text": words(test)}))

    def _target(self, kind: TargetKind, target_id: str) -> Target:
        if kind == "board":
            self.keeper.require(target_id)
        elif self.store.get_season(target_id) is None:
            raise SeasonNotFound(f"no season {target_id!r}")
        return Target(kind=kind, target_id=target_id)

    def _title(self, target: Target) -> str:
        if target.kind == "board":
            return self.keeper.require(target.target_id).board.title
        season = self.store.get_season(target.target_id)
        return season.title if season is not None else target.target_id
