"""Results to analyse: every lap of a board's submissions as CSV rows, a racer's submissions
over time as CSV, and one run's laps as the metrics JSON that DeepRacer writes and
deepracer-utils reads.

The CSV is for a notebook or a spreadsheet to take as it is: one header row, UTF-8, times in ISO
8601 (UTC, ``Z``), durations in seconds as plain numbers, booleans ``true``/``false``, empty for
nothing. A text cell that a spreadsheet would read as a formula (it starts with ``=``, ``+``,
``-``, ``@``, a tab or a carriage return) is written with a leading ``'``, so a racer's or a
model's name never runs as one.

The run's JSON is the ``{"metrics": [...]}`` of an evaluation metrics file, each lap with the
fields deepracer-utils' ``TrainingMetrics`` reads (``trial``, ``episode``, ``phase``,
``reward_score``, ``completion_percentage``, ``episode_status``,
``elapsed_time_in_milliseconds``, ``start_time``), so ``TrainingMetrics(None, url=...)`` loads a
run straight from the board. ``episode_status`` is ``Lap complete`` for a lap the board counts as
complete (its completion is 100 %, whatever the file said, as the board ranks it).
"""

from __future__ import annotations

import csv
import io
from collections.abc import Iterable, Sequence
from datetime import datetime
from typing import Any

from drboard_assembler.record import EvaluationRun, Record

from . import ranking
from .models.domain import Submission
from .models.views import HistoryItem

#: Every lap of every submission (``drboard export --laps``, ``/boards/{board}/laps.csv``).
LAP_COLUMNS = ("board_id", "racer", "model_name", "submission_id", "submitted_at", "counted",
               "run", "run_file", "scoring_run", "lap", "trial", "time_s", "completion_pct",
               "complete", "status", "off_track", "crashes", "resets")
#: A racer's submissions over time (``drboard history --format csv``, ``/racers/{racer}/submissions.csv``).
HISTORY_COLUMNS = ("submitted_at", "board_id", "model_name", "submission_id", "qualified",
                   "time_s", "best_lap_s", "laps_completed", "best_completion_pct", "counted",
                   "flags")
COMPLETE = "Lap complete"
_FORMULA_STARTS = ("=", "+", "-", "@", "\t", "\r")


def lap_rows(submission: Submission, record: Record, counted: bool) -> list[dict[str, Any]]:
    """One row per lap of each of the submission's evaluation runs, in run and lap order."""
    rows = []
    for number, run in enumerate(record.evaluations, start=1):
        for lap_number, lap in enumerate(run.laps, start=1):
            rows.append({
                "board_id": submission.board_id, "racer": submission.racer,
                "model_name": submission.model_name, "submission_id": submission.submission_id,
                "submitted_at": submission.submitted_at, "counted": counted, "run": number,
                "run_file": run.source, "scoring_run": run.source == submission.score.run,
                "lap": lap_number, "trial": lap.trial, "time_s": lap.time_ms / 1000,
                "completion_pct": lap.completion_pct, "complete": lap.complete,
                "status": lap.status, "off_track": lap.off_track, "crashes": lap.crashes,
                "resets": lap.resets,
            })
    return rows


def history_rows(items: Iterable[HistoryItem]) -> list[dict[str, Any]]:
    return [{"submitted_at": item.submitted_at, "board_id": item.board_id,
             "model_name": item.model_name, "submission_id": item.submission_id,
             "qualified": item.qualified, "time_s": _seconds(item.time_ms),
             "best_lap_s": _seconds(item.best_lap_ms), "laps_completed": item.laps_completed,
             "best_completion_pct": item.best_completion_pct, "counted": item.is_best,
             "flags": " ".join(item.flags)} for item in items]


def csv_text(columns: Sequence[str], rows: Iterable[dict[str, Any]], *, header: bool = True) -> str:
    """The rows as CSV, with the header row unless it was written already (a later page of the
    same file)."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    if header:
        writer.writerow(columns)
    for row in rows:
        writer.writerow([cell(row[column]) for column in columns])
    return out.getvalue()


def cell(value: Any) -> str:
    """One CSV cell as a notebook or spreadsheet reads it without cleaning."""
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, datetime):
        return ranking.timestamp(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return f"{value:.3f}".rstrip("0").rstrip(".") if value != int(value) else str(int(value))
    text = str(value)
    return "'" + text if text.startswith(_FORMULA_STARTS) else text


def _seconds(ms: int | None) -> float | None:
    return None if ms is None else ms / 1000


def run_metrics(run: EvaluationRun) -> dict[str, Any]:
    """One evaluation run's laps as an evaluation metrics file (``{"metrics": [...]}``), with
    the fields deepracer-utils reads; laps are numbered 1.. as ``trial`` and ``episode``."""
    metrics = []
    for number, lap in enumerate(run.laps, start=1):
        item: dict[str, Any] = {
            "trial": number, "episode": number, "phase": "evaluation", "reward_score": None,
            "completion_percentage": lap.completion_pct,
            "episode_status": COMPLETE if lap.complete else lap.status,
            "elapsed_time_in_milliseconds": lap.time_ms,
            "start_time": lap.started_ms, "metric_time": lap.ended_ms,
            "off_track_count": lap.off_track, "crash_count": lap.crashes,
            "reset_count": lap.resets,
        }
        if lap.immobilized is not None:
            item["immobilized_count"] = lap.immobilized
        if lap.reversed is not None:
            item["reversed_count"] = lap.reversed
        metrics.append(item)
    return {"metrics": metrics}
