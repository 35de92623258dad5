"""`drboard assemble` and `drboard push`: run folders into records, and records onto a board."""

from __future__ import annotations

import signal
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from ..choices import RACE_TYPES
from ..main import Context, edge, err, interrupt, out, pass_context

if TYPE_CHECKING:
    from drboard_assembler import Overrides, Record


def overrides_options(command: Callable[..., Any]) -> Callable[..., Any]:
    for option in reversed([
        click.option("--track", help="The track (WORLD_NAME, alias or display name), when the "
                                     "files do not say or say otherwise."),
        click.option("--custom-track", is_flag=True,
                     help="Take --track exactly as the name of a track of your own."),
        click.option("--racer", help="Your racer alias, when the files do not say or say otherwise."),
        click.option("--model", help="The model name (default: from the files, else the folder)."),
        click.option("--race-type", type=click.Choice(RACE_TYPES, case_sensitive=False),
                     help="The race type, when the files do not say or say otherwise (a run "
                          "with parameters that leave it out is a time trial)."),
    ]):
        command = option(command)
    return command


def _overrides(track: str | None, custom_track: bool, racer: str | None,
               model: str | None, race_type: str | None) -> Overrides:
    from drboard_assembler import Overrides

    if custom_track and not track:
        raise click.UsageError("--custom-track needs --track NAME")
    return Overrides(track=track, racer=racer, model=model, custom_track=custom_track,
                     race_type=race_type)


@click.command(name="assemble")
@click.argument("path", type=click.Path(exists=True, path_type=Path))
@overrides_options
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Save the record to this file instead of printing it.")
def assemble_command(path: Path, track: str | None, custom_track: bool, racer: str | None,
                     model: str | None, race_type: str | None, output: Path | None) -> None:
    """Read a run folder (or a .tar.gz of one) into a record. Nothing is sent.

    PATH holds the model's files as DeepRacer-for-Cloud, DeepRacer on AWS or the old console
    wrote them: model_metadata.json, hyperparameters.json, the params YAML files and the
    training and evaluation metrics.
    """
    from drboard_assembler import assemble

    with edge():
        record = assemble(path, _overrides(track, custom_track, racer, model, race_type))
        text = record.model_dump_json(indent=2) + "\n"
        if output:
            output.write_text(text, "utf-8")
            err().print(f"Saved the record of {record.racer} on {record.track} to {output}",
                        markup=False)
        else:
            click.echo(text, nl=False)


@click.command()
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@overrides_options
@click.option("--board", "board_id", help="Push to this board (default: the track's board).")
@click.option("--dry-run", is_flag=True, help="Assemble and check, but send nothing.")
@click.option("--watch", is_flag=True,
              help="PATH is a training folder: keep watching it and push each evaluation as it "
                   "finishes, one submission per evaluation metrics file, until Ctrl-C.")
@click.option("--interval", type=click.FloatRange(min=0.1), default=10.0, show_default=True,
              metavar="SECONDS", help="With --watch: how often to look for new evaluations.")
@click.option("--only-new", is_flag=True,
              help="With --watch: leave out the evaluations already in the folder when the watch "
                   "starts.")
@pass_context
def push(ctx: Context, paths: tuple[Path, ...], track: str | None, custom_track: bool,
         racer: str | None, model: str | None, race_type: str | None, board_id: str | None,
         dry_run: bool, watch: bool, interval: float, only_new: bool) -> None:
    """Assemble each run folder and submit it to the board.

    Every path is read and checked first, and, with several, checked against the board too
    (its track, direction and race type, whether it is open, its cooldown and maximum): if one
    is bad, nothing is pushed and the message names it. Then it says what it will push, and
    pushes each run in turn, printing its rank and whether it is a new best; a run the board
    refuses then is named and the others still go, and a summary ends the batch (exit 1 if any
    was refused). Pushing the same run twice changes nothing.

    With --watch, PATH is a folder a training writes to: every evaluation in it (unless
    --only-new) and every new one is pushed on its own once complete, i.e. once its metrics file
    holds every lap its parameters ask for (NUMBER_OF_TRIALS) or, when they do not say, nothing
    has written to it for a minute. The board's cooldown is waited out and an unreachable board
    retried; an evaluation the board refuses is reported and skipped. Ctrl-C stops.
    """
    from drboard_assembler import assemble

    from .. import config, render
    from .standings import keep_standings

    with edge():
        overrides = _overrides(track, custom_track, racer, model, race_type)
        if watch:
            _watch(ctx, paths, overrides, board_id, interval, only_new, dry_run)
            return
        interval_given = click.get_current_context().get_parameter_source("interval")
        if only_new or interval_given is not click.core.ParameterSource.DEFAULT:
            raise click.UsageError("--interval and --only-new go with --watch")
        records = [assemble(path, overrides) for path in paths]
        if dry_run:
            for path, record in zip(paths, records, strict=True):
                _print_dry_run(path, record)
            return
        if len(records) == 1:
            receipt = ctx.board.push(records[0], board_id)
            out().print(render.receipt_line(receipt), soft_wrap=True)
            _say_where(ctx)
            keep_standings(ctx, [receipt.board_id])
        else:
            _push_batch(ctx, paths, records, board_id)
        config.save_settings(last_racer=records[-1].racer)


def _push_batch(ctx: Context, paths: tuple[Path, ...], records: list[Record],
                board_id: str | None) -> None:
    """Several runs: checked against the board first (none pushed if one cannot go), then each
    pushed in turn; a refusal names its run and the others still go; a summary ends it."""
    from drboard_functions.errors import BoardUnreachable, DomainError

    from .. import render
    from ..main import domain_exit_code, fail
    from .standings import keep_standings

    if board_id:
        _check_batch(ctx, paths, records, board_id)
    where = board_id or "each run's track board"
    err().print(f"Pushing {len(records)} runs to {where} {ctx.place}, one at a time; a run the "
                "board refuses is named and the others still go.", soft_wrap=True)
    refused: list[tuple[Path, DomainError]] = []
    pushed_to: list[str] = []
    for path, record in zip(paths, records, strict=True):
        try:
            receipt = ctx.board.push(record, board_id)
        except BoardUnreachable:
            raise
        except DomainError as error:
            refused.append((path, error))
            err().print(f"{path}: refused: {error.message}", style="yellow", soft_wrap=True)
            continue
        out().print(render.receipt_line(receipt), soft_wrap=True)
        pushed_to.append(receipt.board_id)
    keep_standings(ctx, pushed_to)
    pushed = len(records) - len(refused)
    if refused:
        named = "; ".join(f"{path} ({type(error).__name__})" for path, error in refused)
        fail(f"pushed {pushed} of {len(records)} runs; refused: {named}",
             max(domain_exit_code(type(error)) for _, error in refused))
    err().print(f"Pushed all {len(records)} runs.", soft_wrap=True)


def _say_where(ctx: Context) -> None:
    """Name the board a push went to: a racer who meant an event's board and is still on the
    one on this computer (no `drboard join` yet, or a mistyped one) sees it at once."""
    if ctx.endpoint:
        err().print(f"Pushed to the board {ctx.place}.", soft_wrap=True)
    else:
        err().print(f"Pushed to the board {ctx.place}. To push to an event's board instead, run the "
                    "`drboard join` line its screen shows.", soft_wrap=True)


def _check_batch(ctx: Context, paths: tuple[Path, ...], records: list[Record], board_id: str) -> None:
    """Refuse the whole batch, naming the run, when one cannot go on the named board."""
    from collections import Counter

    from drboard_functions.display import duration
    from drboard_functions.models.domain import BoardStatus, run_mismatches

    from ..main import BAD_INPUT, FAILURE, fail

    board = ctx.board.board_page(board_id, 1, None).board
    for path, record in zip(paths, records, strict=True):
        wrong = run_mismatches(record.track, record.direction, record.race_type, board)
        if wrong:
            fail(f"{path}: this run does not belong on {board_id!r} (its {', '.join(wrong)} "
                 "differs): nothing was pushed", BAD_INPUT)
    if board.status is not BoardStatus.OPEN:
        fail(f"{board_id} is {board.status.value.lower()}: nothing was pushed", FAILURE)
    for racer, count in Counter(record.racer for record in records).items():
        if board.cooldown_s and count > 1:
            fail(f"{board_id} takes one push from {racer} every {duration(board.cooldown_s)}, and "
                 f"these are {count} runs of theirs: push them one at a time; nothing was pushed",
                 FAILURE)
        if board.max_submissions is not None and count > board.max_submissions:
            fail(f"{board_id} takes at most {board.max_submissions} submissions from {racer}, and "
                 f"these are {count}: nothing was pushed", FAILURE)


def _watch(ctx: Context, paths: tuple[Path, ...], overrides: Overrides, board_id: str | None,
           interval_s: float, only_new: bool, dry_run: bool) -> None:
    from .. import config
    from ..watch import PushedEvaluations, Watcher

    if len(paths) != 1:
        raise click.UsageError("--watch takes one training folder")
    if dry_run:
        raise click.UsageError("--watch and --dry-run do not go together")
    if not paths[0].is_dir():
        raise click.UsageError(f"--watch needs a training folder; {paths[0]} is not a folder")
    target = ctx.endpoint or str(ctx.db.resolve())
    memory = PushedEvaluations(config.watch_memory_path(), f"{target} {board_id or ''}".strip())
    err().print(f"Pushing to the board {ctx.place}.", soft_wrap=True)
    watcher = Watcher(paths[0], ctx.board, overrides, board_id, console=out(),
                      interval_s=interval_s, only_new=only_new, memory=memory)
    previous = signal.signal(signal.SIGTERM, interrupt)  # stop as Ctrl-C does
    try:
        watcher.run()
    finally:
        signal.signal(signal.SIGTERM, previous)
        if watcher.summary.last_racer:
            config.save_settings(last_racer=watcher.summary.last_racer)


def _print_dry_run(path: Path, record: Record) -> None:
    from drboard_functions import display

    best = min((run.best_lap_ms for run in record.evaluations if run.best_lap_ms), default=None)
    done = max(run.best_completion_pct for run in record.evaluations)
    result = display.seconds(best) if best else f"{display.percent(done)} done"
    out().print(f"{path}: {record.racer} · {record.model_name} · {record.track} · "
                f"{len(record.evaluations)} evaluation runs · best {result} · not sent (dry run)",
                soft_wrap=True, markup=False)
