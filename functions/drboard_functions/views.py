"""The view models the API serialises and the CLI prints, built from what the store holds."""

from __future__ import annotations

from datetime import datetime

from drboard_assembler.catalog import default_catalog
from drboard_assembler.record import Record

from .models.domain import Design, Entry, Submission
from .models.views import BoardView, EntryView, HistoryItem
from .stores.base import StoredBoard


def design_of(record: Record) -> Design:
    """The facts of a record's design an entry keeps (and shows while the board allows)."""
    space = record.design.action_space
    return Design(
        algorithm=record.design.algorithm,
        action_space=space.type if space else None,
        actions=len(space.actions) if space and space.actions else None,
        max_speed=space.max_speed if space else None,
        max_steering=space.max_steering if space else None,
        sensors=list(record.design.sensors) if record.design.sensors is not None else None,
    )


def board_view(stored: StoredBoard, now: datetime) -> BoardView:
    board = stored.board
    track = default_catalog().get(board.track)
    return BoardView(
        board_id=board.board_id,
        kind=board.kind,
        title=board.title,
        description=board.description,
        track=board.track,
        track_name=track.display_name if track else board.track,
        direction=board.direction,
        race_type=board.race_type,
        method=board.rules.method,
        min_laps=board.rules.min_laps,
        flagged_runs=board.rules.flagged_runs,
        conditions=board.rules.conditions,
        designs=board.designs,
        status=board.status(now),
        opens_at=board.opens_at,
        closes_at=board.closes_at,
        cooldown_s=board.cooldown_s,
        max_submissions=board.max_submissions,
        participants=stored.participants,
        version=stored.version,
    )


def page_tag(board: BoardView) -> str:
    """What a board's page depends on besides its query: its version, and its status (which
    the clock moves without a write)."""
    return f"{board.version}.{board.status.value}"


def entry_view(entry: Entry, rank: int, leader: Entry | None, *, design: bool = True) -> EntryView:
    gap = None
    if entry.score.time_ms is not None and leader and leader.score.time_ms is not None:
        gap = entry.score.time_ms - leader.score.time_ms
    return EntryView(
        rank=rank,
        racer=entry.racer,
        model_name=entry.model_name,
        qualified=entry.score.qualified,
        time_ms=entry.score.time_ms,
        gap_ms=gap,
        best_lap_ms=entry.score.best_lap_ms,
        laps_completed=entry.score.laps_completed,
        best_completion_pct=entry.score.best_completion_pct,
        submitted_at=entry.achieved_at,
        submission_id=entry.submission_id,
        design=entry.design if design else None,
        flags=entry.score.flags,
        conditions=entry.score.conditions,
    )


def history_item(submission: Submission, best: Entry | None) -> HistoryItem:
    return HistoryItem(
        board_id=submission.board_id,
        submission_id=submission.submission_id,
        submitted_at=submission.submitted_at,
        model_name=submission.model_name,
        qualified=submission.score.qualified,
        time_ms=submission.score.time_ms,
        best_lap_ms=submission.score.best_lap_ms,
        laps_completed=submission.score.laps_completed,
        best_completion_pct=submission.score.best_completion_pct,
        is_best=best is not None and best.submission_id == submission.submission_id,
        flags=submission.score.flags,
    )
