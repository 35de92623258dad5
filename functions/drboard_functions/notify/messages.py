"""What an announcement says, and the body each chat service takes.

Messages are one or two short lines: who, which model, the time, the gap and how the rank moved,
and a link to the board's page. Names come from racers: they are escaped for the service's own
markup (Discord's Markdown, Slack's ``&<>``), and Discord is told to ping no one whatever a name
holds (``allowed_mentions``).
"""

from __future__ import annotations

import re
from typing import Any

from ..display import gap, seconds, when
from ..models.notices import Announcement, WebhookKind

USERNAME = "drboard"
_MEDALS = {1: "🥇", 2: "🥈", 3: "🥉"}
_DISCORD_MARKUP = re.compile(r"([\\*_~`|>#\[\]()<@:-])")


def words(a: Announcement, name: Any = str) -> str:
    """The announcement in plain words; ``name`` writes each name (escaped for a service)."""
    board = name(a.board_title)
    if a.test:
        standing = words(a.model_copy(update={"test": False}), name).split(". ", 1)[1] if a.podium else ""
        return f"🧪 A test from drboard: announcements of {board} come here. {standing}".strip()
    if a.kind == "board-open":
        until = f" until {when(a.closes_at)}" if a.closes_at else ""
        return f"🟢 {board} is open: push your runs{until}."
    if a.kind == "board-close":
        places = ", ".join(
            f"{_MEDALS.get(p.rank, f'#{p.rank}')} {name(p.racer)} {seconds(p.time_ms)}"
            + (f" ({gap(p.gap_ms)})" if p.gap_ms else "") for p in a.podium)
        return f"🏁 {board} has closed. " + (f"Podium: {places}." if places else "No one finished.")
    racer, model = name(a.racer or ""), name(a.model_name or "")
    move = _movement(a)
    if a.kind == "new-leader":
        ahead = f", {gap(a.gap_ms).lstrip('+')} ahead of {name(a.previous_leader)}" \
            if a.previous_leader and a.gap_ms else ""
        return f"🏆 {racer} leads {board} with {model}: {seconds(a.time_ms)}{ahead} ({move})."
    if a.kind == "top-3":
        return (f"{_MEDALS.get(a.rank or 0, '🏎')} {racer} enters the top 3 on {board} with {model}: "
                f"{seconds(a.time_ms)}, {gap(a.gap_ms)} to the leader ({move}).")
    to_leader = "the leader" if a.rank == 1 else f"{gap(a.gap_ms)} to the leader"
    if a.previous_rank is None:
        return f"⏱ {racer} is on {board} with {model}: {seconds(a.time_ms)}, {to_leader} ({move})."
    return f"⏱ {racer} improves to {seconds(a.time_ms)} on {board} with {model}: {to_leader} ({move})."


def _movement(a: Announcement) -> str:
    if a.previous_rank is None:
        return f"new at #{a.rank}"
    if a.previous_rank == a.rank:
        return f"stays #{a.rank}"
    return f"#{a.previous_rank} → #{a.rank}"


def payload(kind: WebhookKind, a: Announcement) -> dict[str, Any]:
    """The JSON body the webhook's service takes."""
    if kind == "discord":
        text = words(a, _discord_name) + f"\n<{a.url}>"
        return {"username": USERNAME, "content": text[:2000], "allowed_mentions": {"parse": []}}
    if kind == "slack":
        link = f"<{_slack(a.url)}|{_slack(a.board_title)}>"
        return {"text": words(a, _slack) + f" {link}", "unfurl_links": False}
    return {"event": a.kind, "text": words(a) + f" {a.url}",
            "announcement": a.model_dump(mode="json", exclude={"text"})}


def _discord_name(text: str | None) -> str:
    return _DISCORD_MARKUP.sub(r"\\\1", text or "")


def _slack(text: str | None) -> str:
    return (text or "").replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
