"""How results look: rich tables for people, JSON, CSV and Markdown for scripts and posts.

What the board stores is text, never markup: every table cell and title goes to rich as a
``Text`` (a racer named ``[link=…]`` is shown as written), and the consoles escape control
characters (:mod:`.terminal`). A CSV cell that a spreadsheet would take for a formula is
neutralised (:func:`csv_cell`). The standings table, which imports no model, is in
:mod:`.standings_table` (and named here too).
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterable
from datetime import UTC, datetime, timedelta
from typing import IO, TYPE_CHECKING, Any

from drboard_functions import conditions
from drboard_functions.display import (
    DASH,
    PRIVATE_DESIGN,
    UNKNOWN,
    algorithm_name,
    design_summary,
    duration,
    gap,
    method_label,
    percent,
    plural,
    seconds,
    when,
)
from drboard_functions.flags import DESCRIPTIONS
from drboard_functions.insights import LABELS, fact_text
from drboard_functions.laps import cell as formula_safe
from drboard_functions.models.domain import AuditEvent, BoardStatus, Design
from drboard_functions.models.organiser_views import AliasView, FlaggedRun, Moderation
from drboard_functions.models.racer_views import (
    Comparison,
    Insights,
    RacerStatus,
    RacerSummary,
    RacerView,
)
from drboard_functions.models.views import (
    BoardPage,
    BoardView,
    EntryView,
    HistoryItem,
    Me,
    PushAccepted,
    PushReceipt,
)
from rich.console import Console, Group
from rich.table import Table
from rich.text import Text

from .standings_table import FLAG_MARK, plain_row, time_label
from .standings_table import board_table as board_table  # the standings, named here too
from .standings_table import print_standings as print_standings
from .terminal import printable

if TYPE_CHECKING:  # what only some commands show loads with them: `pull` never loads the export's
    from drboard_assembler.record import Record
    from rich.panel import Panel
    from rich.progress import Progress

    from .invite import Invited
    from .transfer import ExportCounts, ImportSummary

_STATUS_STYLE = {BoardStatus.OPEN: "green", BoardStatus.UPCOMING: "yellow", BoardStatus.CLOSED: "dim"}


def _track_label(board: BoardView) -> str:
    label = board.track_name + (" (clockwise)" if board.direction == "cw" else "")
    return label if board.race_type.value == "TIME_TRIAL" else f"{label}, {board.race_type.value}"


def _status_label(board: BoardView) -> Text:
    return Text(board.status.value.lower(), style=_STATUS_STYLE[board.status])


def boards_table(boards: list[BoardView], width: int = 120) -> Table:
    """Each board's id and title, track, timing, status and window; on a narrow terminal the
    title gives way and the window goes under the status."""
    wide = width >= 110
    table = Table(title=Text("Boards"), header_style="bold")
    table.add_column("Board", no_wrap=True)  # ids are typed in other commands: never cut
    columns = ("Track", "Method", "Status", "Opens", "Closes") if wide else ("Track", "Method", "Status")
    for name in columns:
        table.add_column(name, overflow="fold")
    table.add_column("Racers", justify="right")
    for board in boards:
        cells: list[Text | str] = [_board_label(board) if wide else board.board_id,
                                   Text(_track_label(board)), method_label(board)]
        if wide:
            cells += [_status_label(board), when(board.opens_at), when(board.closes_at)]
        else:
            cells.append(_status_label(board) + _window_label(board))
        plain_row(table, *cells, str(board.participants))
    return table


def _board_label(board: BoardView) -> Text:
    return Text.assemble(board.board_id, (f"\n{board.title}", "dim"))


def _window_label(board: BoardView) -> str:
    if board.status is BoardStatus.UPCOMING:
        return f"\nopens {when(board.opens_at)}"
    if board.closes_at is None:
        return ""
    return f"\n{'closes' if board.status is BoardStatus.OPEN else 'closed'} {when(board.closes_at)}"


def board_panel(board: BoardView) -> Panel:
    """One board's settings, as an organiser set them."""
    from rich.panel import Panel

    grid = Table.grid(padding=(0, 2))
    grid.add_column(style="bold")
    grid.add_column()
    plain_row(grid, "Status", _status_label(board))
    plain_row(grid, "Track", Text(f"{_track_label(board)} ({board.track})"))
    plain_row(grid, "Timing", method_label(board))
    plain_row(grid, "Flagged runs", "rank" if board.flagged_runs == "rank"
                 else "shown below the qualified racers, unranked")
    plain_row(grid, "Conditions", conditions.summary(board.conditions) if board.conditions
         else "any (each entry shows its own)")
    plain_row(grid, "Opens", when(board.opens_at) if board.opens_at else "when created")
    plain_row(grid, "Closes", when(board.closes_at) if board.closes_at else "never")
    cooldown = f"{duration(board.cooldown_s)} between a racer's submissions" if board.cooldown_s else "none"
    plain_row(grid, "Cooldown", cooldown)
    cap = board.max_submissions
    plain_row(grid, "Submissions", f"at most {cap} per racer" if cap else "unlimited")
    plain_row(grid, "Racers", str(board.participants))
    if board.description:
        plain_row(grid, "Description", Text(board.description))
    kind = "named board" if board.kind == "named" else "track's default board"
    return Panel(grid, title=Text(f"{board.title} · {board.board_id}", style="bold"), subtitle=kind,
                 expand=False)


def import_summary(summary: ImportSummary) -> Text:
    board = summary.board
    text = Text()
    text.append(board.board_id, style="bold")
    text.append(" (created)" if summary.board_created else " (existing board: its settings kept)")
    text.append(f": {summary.created} submissions imported, {summary.duplicates} already there")
    text.append(f" · {plural(board.participants, 'racer')} ranked by {method_label(board)}")
    if summary.entry_lines:
        text.append(f" · the file's {summary.entry_lines} entries were recomputed, not copied",
                    style="dim")
    return text


def export_line(board_id: str, counts: ExportCounts, output: str | None) -> Text:
    where = f" to {output}" if output else ""
    return Text(f"Exported {board_id}: {plural(counts.entries, 'entry', 'entries')}, "
                f"{plural(counts.submissions, 'submission')}{where}")


def laps_line(board_id: str, rows: int, output: str | None) -> Text:
    where = f" to {output}" if output else ""
    return Text(f"Exported {plural(rows, 'lap')} of {board_id}{where}")


def progress(console: Console) -> Progress:
    """A progress bar on a terminal; nothing when the output is a file or a pipe."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    return Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeRemainingColumn(), console=console, transient=True,
                    disable=not console.is_terminal)


CSV_FIELDS = ["rank", "racer", "model_name", "qualified", "time_s", "gap_s", "best_lap_s",
              "laps_completed", "best_completion_pct", "algorithm", "action_space", "actions",
              "max_speed", "max_steering", "submitted_at", "submission_id", "conditions"]


def _flat(entry: EntryView) -> dict[str, Any]:
    def s(ms: int | None) -> str:
        return "" if ms is None else f"{ms / 1000:.3f}"

    return {
        "rank": entry.rank, "racer": entry.racer, "model_name": entry.model_name,
        "qualified": entry.qualified, "time_s": s(entry.time_ms), "gap_s": s(entry.gap_ms),
        "best_lap_s": s(entry.best_lap_ms), "laps_completed": entry.laps_completed,
        "best_completion_pct": entry.best_completion_pct,
        "submitted_at": entry.submitted_at.isoformat(), "submission_id": entry.submission_id,
        "conditions": conditions.short(entry.conditions),
    } | _flat_design(entry.design)


def _flat_design(design: Design | None) -> dict[str, Any]:
    """The design's columns: empty while the board keeps designs private, ``unknown`` where the
    run's files do not state a fact."""
    if design is None:  # the board keeps designs private until it closes
        return dict.fromkeys(("algorithm", "action_space", "actions", "max_speed", "max_steering"), "")
    space_known = design.action_space is not None
    return {"algorithm": design.algorithm or UNKNOWN, "action_space": design.action_space or UNKNOWN,
            "actions": design.actions or ("" if space_known else UNKNOWN),
            "max_speed": design.max_speed if space_known else UNKNOWN,
            "max_steering": design.max_steering if space_known else UNKNOWN}


def csv_cell(value: Any) -> Any:
    """A CSV cell as a spreadsheet should read it: text starting like a formula (``=``, ``+``,
    ``-``, ``@``, a tab or a carriage return) gets a leading ``'`` (the rule of
    :func:`drboard_functions.laps.cell`, which the laps' CSV uses too), and control characters
    are escaped; numbers are written as they are."""
    if not isinstance(value, str):
        return value
    return formula_safe(printable(value))


def write_csv(rows: Iterable[dict[str, Any]], fields: list[str]) -> str:
    """CSV text of the rows, every cell through :func:`csv_cell`: the one way drboard writes CSV."""
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=fields, lineterminator="\n")
    writer.writeheader()
    writer.writerows({name: csv_cell(value) for name, value in row.items()} for row in rows)
    return out.getvalue()


def board_csv(page: BoardPage) -> str:
    return write_csv((_flat(entry) for entry in page.entries), CSV_FIELDS)


def board_markdown(page: BoardPage) -> str:
    board = page.board
    lines = [f"## {board.title} ({board.board_id})", "",
             f"{plural(board.participants, 'racer')} · {method_label(board)}", "",
             "| Rank | Racer | Model | Time | Gap | Laps | Design |",
             "|---:|---|---|---:|---:|---:|---|"]
    for entry in page.entries:
        cells = [str(entry.rank), entry.racer, entry.model_name, time_label(entry),
                 gap(entry.gap_ms), str(entry.laps_completed), design_summary(entry.design)]
        lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
    return printable("\n".join(lines) + "\n")


def board_json(page: BoardPage) -> str:
    return json_text(page.model_dump_json(indent=2) + "\n")


def json_text(text: str) -> str:
    """JSON text as a terminal may show it: a control or bidirectional character inside a
    string is written as its ``\\uXXXX`` escape (the same JSON once parsed)."""
    return printable(text)


# ---- push, history, show ---------------------------------------------------------------------


def receipt_line(receipt: PushReceipt | PushAccepted) -> Text:
    if isinstance(receipt, PushAccepted):
        text = Text()
        text.append(receipt.racer, style="bold")
        text.append(f" · {receipt.board_id} · {receipt.message}", style="yellow")
        return text
    entry = receipt.entry
    pushed = receipt.submission
    result = seconds(pushed.time_ms) if pushed.qualified else (
        f"{percent(pushed.best_completion_pct)} done, not qualified")
    text = Text()
    text.append(f"{entry.racer}", style="bold")
    text.append(f" · {pushed.model_name} · {receipt.board_id} · {result} · ")
    text.append(f"rank {receipt.rank} of {receipt.participants}", style="bold")
    if receipt.status == "duplicate":
        text.append(" · already on the board, nothing changed", style="yellow")
    elif receipt.improved:
        text.append(" · new best", style="green")
    else:
        text.append(f" · not better than your best ({time_label(entry)})", style="yellow")
    if receipt.rank > 1 and entry.gap_ms is not None:
        text.append(f" · {gap(entry.gap_ms)} to the leader")
    return text


def history_table(racer: str, items: Iterable[HistoryItem], width: int = 120) -> Table:
    """The racer's submissions; on a narrow terminal the date is shorter and the best lap goes."""
    wide = width >= 100
    table = Table(title=Text(f"History of {racer}"), header_style="bold")
    table.add_column("Submitted", no_wrap=True)
    table.add_column("Board", no_wrap=True)
    table.add_column("Model", no_wrap=True, overflow="ellipsis")
    table.add_column("Result", no_wrap=True, justify="right")
    if wide:
        table.add_column("Best lap", no_wrap=True, justify="right")
    table.add_column("Laps", justify="right")
    table.add_column("Best")
    for item in items:
        result = seconds(item.time_ms) if item.qualified else f"{percent(item.best_completion_pct)}"
        cells = [item.submitted_at.strftime("%Y-%m-%d %H:%M:%S" if wide else "%m-%d %H:%M"),
                 item.board_id, item.model_name, result]
        if wide:
            cells.append(seconds(item.best_lap_ms))
        plain_row(table, *cells, str(item.laps_completed), "★" if item.is_best else "")
    return table


def moderation_line(moderation: Moderation, action: str) -> Text:
    board = moderation.board
    said = {
        "remove-entry": (f"Took {moderation.racer} off {board.board_id}." if moderation.entry_removed
                         else f"{moderation.racer} had no entry on {board.board_id}."),
        "ban": (f"Banned {moderation.racer} from "
                + ("every board of this event" if moderation.everywhere else board.board_id)
                + (f" (and their sign-in {moderation.principal}, under any alias)"
                   if moderation.principal else "") + ": their pushes are refused."),
        "unban": f"{moderation.racer} may push to {board.board_id} again.",
    }[action]
    return Text(f"{said} {plural(board.participants, 'racer')} on the board; every submission "
                "is kept (`drboard audit " + board.board_id + "` lists who did what).")


def audit_table(board_id: str, events: Iterable[AuditEvent], width: int = 120) -> Table:
    """Who did what: each sign-in by the racer alias it pushes as (a joined racer's ``join:`` id
    is no name), each change in words; on a narrow terminal the submission id gives way."""
    events = list(events)
    aliases = {event.actor: event.racer for event in events if event.action == "push" and event.racer}
    wide = width >= 100
    table = Table(title=Text(f"Audit trail of {board_id}"), header_style="bold")
    table.add_column("When (UTC)", no_wrap=True)
    table.add_column("Action", no_wrap=True)
    table.add_column("Who")
    table.add_column("Racer")
    if wide:
        table.add_column("Submission", no_wrap=True)
    table.add_column("What", ratio=1)
    for event in events:
        cells = [event.at.astimezone(UTC).strftime("%m-%d %H:%M:%S"), event.action,
                 actor_label(event.actor, event.actor_name, aliases.get(event.actor)),
                 event.racer or ""]
        if wide:
            cells.append((event.submission_id or "")[:12])
        cells.append(audit_detail(event))
        plain_row(table, *cells)
    return table


def actor_label(principal: str, name: str, alias: str | None) -> str:
    """Who a sign-in is, for people: the organiser at the board's computer, a racer by the alias
    they push as, an IAM caller by the last part of its ARN."""
    kind = principal.partition(":")[0]
    if principal == "local":
        return "organiser (this computer)"
    if kind == "join":
        return f"{alias} (joined)" if alias else f"a joined racer ({principal[5:13]})"
    if kind == "iam":
        return f"organiser (IAM {principal.rsplit('/', 1)[-1]})"
    shown = name or alias or principal
    return f"{shown} (as {alias})" if alias and alias != shown else shown


#: How the board's settings read in an audit line ("title", "closes at", ...).
_SETTING_NAMES = {"cooldown_s": "cooldown", "max_submissions": "max submissions",
                  "min_laps": "min laps", "opens_at": "opens at", "closes_at": "closes at",
                  "flagged_runs": "flagged runs"}


def audit_detail(event: AuditEvent) -> str:
    """An event's detail in words: a board's changes as ``title → Club final; cooldown →
    30 min``, a push's model, a creation's title."""
    if event.action == "update":
        try:
            changes = json.loads(event.detail)
        except ValueError:
            changes = None
        if isinstance(changes, dict):
            return "; ".join(f"{_SETTING_NAMES.get(name, name.replace('_', ' '))} → "
                             f"{_setting_text(name, value)}" for name, value in changes.items())
    if event.action == "push" and event.detail:
        return f"model {event.detail}"
    return event.detail


def _setting_text(name: str, value: Any) -> str:
    if value is None:
        return "none"
    if name == "cooldown_s" and isinstance(value, int):
        return duration(value) if value else "none"
    if name in ("opens_at", "closes_at") and isinstance(value, str):
        try:
            return when(datetime.fromisoformat(value))
        except ValueError:
            return value
    return str(value)


def alias_table(views: Iterable[AliasView], title: str = "Aliases") -> Table:
    table = Table(title=Text(title), header_style="bold")
    for name in ("Alias", "Held by", "Since (UTC)"):
        table.add_column(name, overflow="fold")
    for view in views:
        holder = "reserved for its racer" if view.reserved else view.principal
        plain_row(table, view.alias, holder, view.claimed_at.astimezone(UTC).strftime("%Y-%m-%d %H:%M"))
    return table


def invite_table(done: Iterable[Invited]) -> Table:
    table = Table(title=Text("Invited racers"), header_style="bold")
    for name in ("E-mail", "Alias", "User", "Alias is", "Problem"):
        table.add_column(name, overflow="fold")
    users = {"created": "invited now", "existed": "was there", "failed": "not created"}
    aliases = {"theirs": "theirs", "held": "another's", "failed": "not given"}
    for result in done:
        plain_row(table, result.racer.email, result.racer.alias, users[result.user],
             aliases[result.alias], result.problem, style=None if result.ok else "yellow")
    return table


def invite_summary(done: list[Invited]) -> Text:
    created = sum(result.user == "created" for result in done)
    existed = sum(result.user == "existed" for result in done)
    problems = sum(not result.ok for result in done)
    return Text(f"{plural(created, 'racer')} invited, {existed} already users, "
                f"{plural(problems, 'problem')}; every invited racer's alias is theirs"
                if not problems else
                f"{plural(created, 'racer')} invited, {existed} already users, "
                f"{plural(problems, 'racer')} not done (see the table): run it again once fixed")


def recheck_line(board_id: str, checked: int, flagged: list[FlaggedRun]) -> Text:
    text = Text(f"Rechecked {board_id}: {plural(checked, 'submission')}, ")
    text.append(f"{plural(len(flagged), 'run')} flagged for you", style="yellow" if flagged else "")
    for run in flagged:
        text.append(f"\n  {FLAG_MARK} {run.racer} · {run.flag}: {run.why}")
    return text


def me_line(me: Me) -> Text:
    role = "an organiser" if me.organiser else "a racer"
    alias = f"you push as {me.alias}" if me.alias else "no alias yet (your first push claims one)"
    return Text(f"Signed in as {me.name or me.principal} ({me.principal}), {role}; {alias}.")


def status_table(summary: RacerSummary, width: int = 120) -> Table:
    """Per board: the racer's latest submission, where their best stands, what they have left.
    On a narrow terminal the gap goes under the rank, and no word is cut."""
    wide = width >= 100
    table = Table(title=Text(f"Status of {summary.racer}"), header_style="bold")
    table.add_column("Board", no_wrap=True)
    table.add_column("Latest", no_wrap=True, overflow="ellipsis", max_width=24)
    table.add_column("Result")
    table.add_column("Rank", no_wrap=True)
    if wide:
        table.add_column("Gap", no_wrap=True)
    table.add_column("Used", no_wrap=True)
    table.add_column("Next")
    for status in summary.boards:
        latest = status.latest
        result = _result(latest).replace(" s", "\u00a0s")  # a time and its unit stay together
        if not latest.is_best:
            result += f" (best {time_label(status.entry)})"
        rank = f"{status.entry.rank} of {status.board.participants}"
        cells: list[Text | str] = [
            _board_label(status.board),
            Text(f"{latest.submitted_at:%b %d %H:%M}\n{latest.model_name}", no_wrap=True,
                 overflow="ellipsis"),
            result,
        ]
        cells += [rank, gap(status.entry.gap_ms)] if wide else [f"{rank}\n{gap(status.entry.gap_ms)}"]
        cells += [_submissions_label(status), next_submission(status)]
        plain_row(table, *cells)
    return table


def _result(item: HistoryItem) -> str:
    return seconds(item.time_ms) if item.qualified else f"{percent(item.best_completion_pct)} done"


def _submissions_label(status: RacerStatus) -> str:
    cap = status.board.max_submissions
    return f"{status.submissions} of {cap}" if cap else str(status.submissions)


def next_submission(status: RacerStatus) -> str:
    """When the racer may submit again on this board, or why they may not."""
    board = status.board
    if board.status is BoardStatus.CLOSED:
        return "board closed"
    if status.submissions_left == 0:
        return "none left"
    if board.status is BoardStatus.UPCOMING:
        return f"opens {when(board.opens_at)}"
    return _minute_after(status.next_submission_at) if status.next_submission_at else "now"


def _minute_after(moment: datetime) -> str:
    """``Mar 01 12:31 UTC`` for 12:30:10: short, and never earlier than the moment itself."""
    moment = moment.astimezone(UTC)
    if moment.second or moment.microsecond:
        moment = moment.replace(second=0, microsecond=0) + timedelta(minutes=1)
    return f"{moment:%b %d %H:%M} UTC"


def deleted_line(board: BoardView) -> Text:
    return Text(f"Deleted {board.board_id} ({plural(board.participants, 'racer')}). Its entries and "
                f"submissions are kept: `drboard board restore {board.board_id}` brings it back, "
                f"`drboard export {board.board_id}` saves it.")


def racer_panel(view: RacerView) -> Group:
    record = view.record
    entry = view.entry
    summary = Table.grid(padding=(0, 2))
    summary.add_column(style="bold")
    summary.add_column()
    plain_row(summary, "Racer", f"{view.racer} · rank {entry.rank} of {view.board.participants} on "
                    f"{view.board.board_id}")
    plain_row(summary, "Result", f"{time_label(entry)} · gap {gap(entry.gap_ms)}")
    if record is None:
        plain_row(summary, "Model", f"{entry.model_name}: how it was built is {PRIVATE_DESIGN}")
        return Group(summary)
    plain_row(summary, "Model", f"{record.model_name} ({record.source_layout.value} files)")
    design = record.design
    plain_row(summary, "Algorithm", algorithm_name(design.algorithm))
    plain_row(summary, "Network", design.neural_network or (UNKNOWN if design.sensors is None else DASH))
    plain_row(summary, "Sensors", UNKNOWN if design.sensors is None else ", ".join(design.sensors) or DASH)
    plain_row(summary, "Read from", design_sources(record))
    plain_row(summary, "Training", training_line(record))
    plain_row(summary, "Conditions", conditions.summary(entry.conditions)
         or "unknown: the evaluation's parameters state none")
    plain_row(summary, "", Text(conditions.PENALTIES_NOTE, style="dim"))
    if entry.flags:
        plain_row(summary, f"Flags {FLAG_MARK}", "; ".join(DESCRIPTIONS.get(f, f) for f in entry.flags))
    return Group(summary, hyperparameter_table(record), action_space_table(record),
                 laps_table(record))


def training_line(record: Record) -> str:
    if record.training is None:
        return "unknown: the run's files hold no training metrics"
    t = record.training
    return (f"{t.episodes} episodes on {t.track or UNKNOWN}, {duration(int(t.training_time_s))}, "
            f"best reward {t.best_reward}, {t.completed_laps} laps completed")


def design_sources(record: Record) -> str:
    """Where each design fact was read: ``action space, algorithm, sensors: model_metadata.json;
    hyperparameters: ip/hyperparameters.json``; a fact no file states, as unknown."""
    sources = record.design.sources
    if sources is None:  # a record from before the sources were kept
        return "the run's files (kept before drboard named each fact's file)"
    by_file: dict[str, list[str]] = {}
    for fact, name in sources.model_dump().items():
        by_file.setdefault(name or UNKNOWN, []).append(fact.replace("_", " "))
    return "; ".join(f"{', '.join(facts)}: {name}" for name, facts in by_file.items())


def comparison_table(comparison: Comparison) -> Table:
    """The racers' designs side by side; the facts they differ on in bold, marked ≠."""
    table = Table(title=Text(f"{' vs '.join(c.racer for c in comparison.racers)} on "
                             f"{comparison.board.board_id}"), header_style="bold")
    table.add_column("")
    table.add_column("Fact")
    for compared in comparison.racers:
        table.add_column(Text(f"{compared.racer} (#{compared.entry.rank}, "
                              f"{time_label(compared.entry)})"))
    for fact, label in LABELS.items():
        differs = fact in comparison.differences
        values = [fact_text(fact, getattr(c.facts, fact), fact in c.facts.unknown)
                  for c in comparison.racers]
        plain_row(table, "≠" if differs else "", label, *values, style="bold" if differs else None)
    return table


def insights_table(insights: Insights) -> Table:
    """What the top models share against the field, one fact a row."""
    table = Table(title=Text(f"The top {insights.top} of {insights.board.board_id} against its "
                             f"{insights.field} entries"), header_style="bold")
    table.add_column("Fact")
    table.add_column(f"Top {insights.top}", justify="right")
    table.add_column("Field", justify="right")
    for fact in insights.facts:
        plain_row(table, fact.label, fact.top + _share(fact.top_share),
             fact.field + _share(fact.field_share))
    return table


def _share(share: float | None) -> str:
    return "" if share is None else f" ({share:.0%})"


def hyperparameter_table(record: Record) -> Table:
    hyper = record.design.hyperparameters
    if hyper is None:
        return _unknown_table("Hyperparameters", "unknown: neither a hyperparameters.json nor the "
                              "model's training log is in the run's files")
    table = Table(title=Text("Hyperparameters"), header_style="bold")
    table.add_column("Name")
    table.add_column("Value", justify="right")
    values = hyper.model_dump(exclude={"other"}, exclude_none=True) | hyper.other
    for name, value in sorted(values.items()):
        plain_row(table, name, str(value))
    return table


def _unknown_table(title: str, text: str) -> Table:
    table = Table(title=Text(title), show_header=False)
    table.add_column("")
    plain_row(table, text)
    return table


def action_space_table(record: Record) -> Table:
    space = record.design.action_space
    if space is None:
        return _unknown_table("Action space", "unknown: the run's files do not describe it")
    if space.type == "continuous" and space.speed and space.steering_angle:
        table = Table(title=Text("Action space (continuous)"), header_style="bold")
        table.add_column("")
        table.add_column("Low", justify="right")
        table.add_column("High", justify="right")
        plain_row(table, "Speed (m/s)", f"{space.speed.low:g}", f"{space.speed.high:g}")
        plain_row(table, "Steering (°)", f"{space.steering_angle.low:g}",
                      f"{space.steering_angle.high:g}")
        return table
    table = Table(title=Text(f"Action space ({len(space.actions or [])} discrete actions)"),
                  header_style="bold")
    for name in ("#", "Steering (°)", "Speed (m/s)"):
        table.add_column(name, justify="right")
    for number, action in enumerate(space.actions or []):
        index = action.index if action.index is not None else number
        plain_row(table, str(index), f"{action.steering_angle:g}", f"{action.speed:g}")
    return table


def laps_table(record: Record) -> Table:
    table = Table(title=Text("Evaluation laps"), header_style="bold")
    for name in ("Run", "Lap", "Time", "Done", "Status", "Off track", "Crashes", "Resets"):
        table.add_column(name)
    for run in record.evaluations:
        for lap in run.laps:
            plain_row(table, run.source.rsplit("/", 1)[-1], str(lap.trial), seconds(lap.time_ms),
                          percent(lap.completion_pct), lap.status, str(lap.off_track),
                          str(lap.crashes), str(lap.resets))
    return table


def write_json(value: Any) -> str:
    return json.dumps(value, indent=2, default=str) + "\n"


def plain_console(file: IO[str]) -> Console:
    return Console(file=file, width=140, no_color=True, highlight=False)
