"""What organisers' commands answer (see ``views``): the audit trail, a moderation's outcome,
aliases, a board's recheck and the building of its rank counters."""

from datetime import datetime

from pydantic import Field

from .domain import AuditEvent, Model
from .views import BoardView


class AuditPage(Model):
    board_id: str
    events: list[AuditEvent]
    next_cursor: str | None = None


class Moderation(Model):
    """What an organiser's remove-entry, ban or unban left."""

    board: "BoardView"
    racer: str
    banned: bool
    entry_removed: bool
    #: Whether the racer is banned from every board of the event (the deployment), not only this one.
    everywhere: bool = False
    #: The sign-in (principal) the ban binds, when the racer's alias is claimed.
    principal: str | None = None


class AliasView(Model):
    """An alias and who holds it: a sign-in's principal, or ``reserved:<alias>`` while an
    organiser keeps it for a racer who has not signed in yet."""

    alias: str
    racer_key: str
    principal: str
    reserved: bool
    claimed_at: datetime


class AliasList(Model):
    aliases: list[AliasView]
    next_cursor: str | None = None


class RecheckPage(Model):
    """One page of a board's recheck: how many stored submissions it went through and what it
    flagged for the organiser; pass ``next_cursor`` until it is null."""

    board_id: str
    checked: int
    flagged: list["FlaggedRun"]
    next_cursor: str | None = None


class FlaggedRun(Model):
    board_id: str
    racer: str
    submission_id: str
    flag: str
    why: str


class RankCounters(Model):
    """How far the building of a board's rank counters got (a board from before them ranks by
    counting its entries until they are built)."""

    board_id: str
    done: bool
    counted: int = Field(description="Entries counted so far.")
    participants: int
