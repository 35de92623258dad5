"""`drboard`: push DeepRacer runs to a leaderboard and see the standings.

Exit codes: 0 success, 2 bad input (a file, a flag, a record the board refuses), 1 failure.
"""

from __future__ import annotations

import signal
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, TypeVar

import click
from drboard_assembler import AssemblyError, Overrides, Record, assemble
from drboard_functions import display
from drboard_functions import errors as domain
from rich.console import Console

from . import config, render
from .target import BoardClient, local_board

FORMATS = ("table", "json", "csv", "markdown")
BAD_INPUT = 2
FAILURE = 1

_BAD_INPUT_ERRORS = (domain.InvalidSubmission, domain.SubmissionTooLarge, domain.BoardMismatch,
                     domain.InvalidQuery)

T = TypeVar("T")

out = Console(highlight=False)
err = Console(stderr=True, highlight=False)


class Context:
    """Which board the commands talk to: ``--endpoint`` (or DRBOARD_ENDPOINT), else ``--db``,
    else the endpoint saved by ``drboard configure``, else the embedded board."""

    def __init__(self, db: Path | None, endpoint: str | None) -> None:
        self.explicit_db = db
        self.db = db or config.default_db_path()
        self.endpoint = endpoint or (None if db else config.load_settings().get("endpoint"))
        self._board: BoardClient | None = None

    @property
    def board(self) -> BoardClient:
        if self._board is None:
            if self.endpoint:
                from .remote import HttpBoard

                self._board = HttpBoard(str(self.endpoint))
            else:
                self._board = local_board(self.db)
        return self._board


pass_context = click.make_pass_decorator(Context)


def fail(message: str, code: int) -> None:
    err.print(f"[bold red]error:[/] {message}", soft_wrap=True, markup=True, highlight=False)
    sys.exit(code)


@contextmanager
def edge() -> Iterator[None]:
    """Map domain errors to one message and an exit code: the CLI's only error handling."""
    try:
        yield
    except AssemblyError as error:
        fail(_escape(str(error)), BAD_INPUT)
    except _BAD_INPUT_ERRORS as error:
        fail(_escape(error.message), BAD_INPUT)
    except domain.DomainError as error:
        fail(_escape(error.message), FAILURE)
    except OSError as error:
        fail(_escape(f"{error.filename or ''} {error.strerror or error}".strip()), FAILURE)


def _escape(text: str) -> str:
    from rich.markup import escape

    return escape(text)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="drboard")
@click.option("--db", type=click.Path(dir_okay=False, path_type=Path), envvar="DRBOARD_DB",
              help="The embedded board's SQLite file (default: in your user data folder). "
                   "Env: DRBOARD_DB.")
@click.option("--endpoint", envvar="DRBOARD_ENDPOINT", metavar="URL",
              help="A deployed board's API URL, or a `drboard serve` on your network. "
                   "Env: DRBOARD_ENDPOINT. Default: the one `drboard configure` saved, if any.")
@click.pass_context
def cli(ctx: click.Context, db: Path | None, endpoint: str | None) -> None:
    """drboard: a leaderboard for AWS DeepRacer racers.

    Push your run folders, see the standings and how the fast models were built.
    """
    ctx.obj = Context(db, endpoint)


# ---- assemble ----------------------------------------------------------------------------


def overrides_options(command: Callable[..., Any]) -> Callable[..., Any]:
    for option in reversed([
        click.option("--track", help="The track (WORLD_NAME, alias or display name), when the "
                                     "files do not say or say otherwise."),
        click.option("--custom-track", is_flag=True,
                     help="Take --track exactly as the name of a track of your own."),
        click.option("--racer", help="Your racer alias, when the files do not say or say otherwise."),
        click.option("--model", help="The model name (default: from the files, else the folder)."),
    ]):
        command = option(command)
    return command


def _overrides(track: str | None, custom_track: bool, racer: str | None,
               model: str | None) -> Overrides:
    if custom_track and not track:
        raise click.UsageError("--custom-track needs --track NAME")
    return Overrides(track=track, racer=racer, model=model, custom_track=custom_track)


@cli.command(name="assemble")
@click.argument("path", type=click.Path(exists=True, path_type=Path))
@overrides_options
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Save the record to this file instead of printing it.")
def assemble_command(path: Path, track: str | None, custom_track: bool, racer: str | None,
                     model: str | None, output: Path | None) -> None:
    """Read a run folder (or a .tar.gz of one) into a record. Nothing is sent.

    PATH holds the model's files as DeepRacer-for-Cloud, DeepRacer on AWS or the old console
    wrote them: model_metadata.json, hyperparameters.json, the params YAML files and the
    training and evaluation metrics.
    """
    with edge():
        record = assemble(path, _overrides(track, custom_track, racer, model))
        text = record.model_dump_json(indent=2) + "\n"
        if output:
            output.write_text(text, "utf-8")
            err.print(f"Saved the record of {record.racer} on {record.track} to {output}")
        else:
            click.echo(text, nl=False)


# ---- push --------------------------------------------------------------------------------


@cli.command()
@click.argument("paths", nargs=-1, required=True, type=click.Path(exists=True, path_type=Path))
@overrides_options
@click.option("--board", "board_id", help="Push to this board (default: the track's board).")
@click.option("--dry-run", is_flag=True, help="Assemble and check, but send nothing.")
@pass_context
def push(ctx: Context, paths: tuple[Path, ...], track: str | None, custom_track: bool,
         racer: str | None, model: str | None, board_id: str | None, dry_run: bool) -> None:
    """Assemble each run folder and submit it to the board.

    Every path is read and checked first: if one is bad, nothing is pushed. Prints each run's
    rank and whether it is a new best. Pushing the same run twice changes nothing.
    """
    with edge():
        overrides = _overrides(track, custom_track, racer, model)
        records = [assemble(path, overrides) for path in paths]
        if dry_run:
            for path, record in zip(paths, records, strict=True):
                _print_dry_run(path, record)
            return
        for record in records:
            receipt = ctx.board.push(record, board_id)
            out.print(render.receipt_line(receipt), soft_wrap=True)
        config.save_settings(racer=records[-1].racer)


def _print_dry_run(path: Path, record: Record) -> None:
    best = min((run.best_lap_ms for run in record.evaluations if run.best_lap_ms), default=None)
    done = max(run.best_completion_pct for run in record.evaluations)
    result = display.seconds(best) if best else f"{display.percent(done)} done"
    out.print(f"{path}: {record.racer} · {record.model_name} · {record.track} · "
              f"{len(record.evaluations)} evaluation runs · best {result} · not sent (dry run)",
              soft_wrap=True)


# ---- pull and boards ---------------------------------------------------------------------


def _board_id(track: str | None, board: str | None) -> str:
    from drboard_functions.service import board_for_track

    if bool(track) == bool(board):
        raise click.UsageError("give one of --track or --board")
    return board if board else board_for_track(track or "")


@cli.command()
@click.option("--track", help="The track whose default board to show (any of its names).")
@click.option("--board", help="The board id to show.")
@click.option("--top", type=click.IntRange(1, 100_000), default=25, show_default=True,
              help="How many entries.")
@click.option("--format", "fmt", type=click.Choice(FORMATS), default="table", show_default=True)
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write to this file instead of the terminal.")
@pass_context
def pull(ctx: Context, track: str | None, board: str | None, top: int, fmt: str,
         output: Path | None) -> None:
    """Show a board's standings: rank, time, gap to the leader and each model's design."""
    with edge():
        page = _collect(ctx.board, _board_id(track, board), top)
        _emit(page, fmt, output)


def _collect(client: BoardClient, board_id: str, top: int) -> Any:
    from drboard_functions.models import MAX_PAGE

    page = client.board_page(board_id, min(top, MAX_PAGE), None)
    entries = list(page.entries)
    cursor = page.next_cursor
    while cursor and len(entries) < top:
        more = client.board_page(board_id, min(top - len(entries), MAX_PAGE), cursor)
        entries.extend(more.entries)
        cursor = more.next_cursor
    return page.model_copy(update={"entries": entries, "next_cursor": cursor})


def _emit(page: Any, fmt: str, output: Path | None) -> None:
    if fmt == "table":
        if output:
            with output.open("w", encoding="utf-8") as handle:
                render.plain_console(handle).print(render.board_table(page))
        elif page.entries:
            out.print(render.board_table(page, out.width))
        else:
            out.print(f"{page.board.title}: no entries yet.")
        return
    text = {"json": render.board_json, "csv": render.board_csv,
            "markdown": render.board_markdown}[fmt](page)
    if output:
        output.write_text(text, "utf-8")
    else:
        click.echo(text, nl=False)


@cli.command()
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True)
@pass_context
def boards(ctx: Context, fmt: str) -> None:
    """List the boards with their track, timing method and number of racers."""
    with edge():
        found = ctx.board.boards()
        if fmt == "json":
            click.echo(render.write_json([b.model_dump(mode="json") for b in found]), nl=False)
        elif found:
            out.print(render.boards_table(found))
        else:
            out.print("No boards yet: push a run with `drboard push PATH`.")


# ---- racers ------------------------------------------------------------------------------


def _racer(racer: str | None) -> str:
    racer = racer or config.load_settings().get("racer")
    if not racer:
        raise click.UsageError("give --racer (no racer has pushed from this machine yet)")
    return str(racer)


@cli.command()
@click.option("--racer", envvar="DRBOARD_RACER",
              help="The racer (default: the last racer who pushed from this machine). "
                   "Env: DRBOARD_RACER.")
@click.option("--track", help="Only this track's default board.")
@click.option("--board", help="Only this board.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True)
@pass_context
def history(ctx: Context, racer: str | None, track: str | None, board: str | None,
            fmt: str) -> None:
    """Every submission of a racer, oldest first; ★ marks the one that counts."""
    with edge():
        name = _racer(racer)
        board_id = _board_id(track, board) if (track or board) else None
        items = ctx.board.history(name, board_id)
        if fmt == "json":
            click.echo(render.write_json([i.model_dump(mode="json") for i in items]), nl=False)
        elif items:
            out.print(render.history_table(name, items))
        else:
            out.print(f"No submissions by {name} yet.")


@cli.command()
@click.argument("racer")
@click.option("--track", help="The track whose default board to look at.")
@click.option("--board", help="The board id to look at.")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True)
@pass_context
def show(ctx: Context, racer: str, track: str | None, board: str | None, fmt: str) -> None:
    """How a racer's best model was built: hyperparameters, action space, laps, training."""
    with edge():
        view = ctx.board.racer(_board_id(track, board), racer)
        if fmt == "json":
            click.echo(view.model_dump_json(indent=2))
        else:
            out.print(render.racer_panel(view))


# ---- targets: configure and serve -------------------------------------------------------


@cli.command()
@click.option("--stack-name", help="Read the board's URL from this CloudFormation stack's outputs.")
@click.option("--region", help="The stack's AWS region (default: your AWS configuration's).")
@click.option("--endpoint", "endpoint_url", metavar="URL",
              help="Use this board URL (a deployed API or a `drboard serve`).")
@click.option("--local", "use_local", is_flag=True, help="Forget the saved URL: use the embedded board.")
@click.option("--racer", help="Your racer alias, the default for `drboard history`.")
def configure(stack_name: str | None, region: str | None, endpoint_url: str | None,
              use_local: bool, racer: str | None) -> None:
    """Choose the board the commands talk to, and save it in your user config folder.

    With no option, shows what is saved.
    """
    with edge():
        if sum(map(bool, (stack_name, endpoint_url, use_local))) > 1:
            raise click.UsageError("give one of --stack-name, --endpoint or --local")
        changes: dict[str, Any] = {}
        if stack_name:
            from .cloud import stack_endpoint

            changes |= {"endpoint": stack_endpoint(stack_name, region), "stack_name": stack_name}
        elif endpoint_url:
            if not endpoint_url.startswith(("http://", "https://")):
                raise click.UsageError("--endpoint must be an http:// or https:// URL")
            changes |= {"endpoint": endpoint_url.rstrip("/"), "stack_name": None}
        elif use_local:
            changes |= {"endpoint": None, "stack_name": None}
        if racer:
            changes["racer"] = racer
        if changes:
            config.save_settings(**changes)
        settings = config.load_settings()
        target = settings.get("endpoint") or f"the embedded board ({config.default_db_path()})"
        out.print(f"Board: {target}", soft_wrap=True)
        if settings.get("stack_name"):
            out.print(f"Stack: {settings['stack_name']}")
        if settings.get("racer"):
            out.print(f"Racer: {settings['racer']}")
        out.print(f"Saved in {config.settings_path()}", style="dim", soft_wrap=True)


@cli.command()
@click.option("--host", default="127.0.0.1", show_default=True,
              help="The address to listen on; 0.0.0.0 lets racers on your network push.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True)
@click.option("--table", help="Serve a DynamoDB table instead of the embedded board.")
@click.option("--endpoint-url", metavar="URL",
              help="With --table: the DynamoDB endpoint, e.g. DynamoDB Local's http://127.0.0.1:8001.")
@pass_context
def serve(ctx: Context, host: str, port: int, table: str | None, endpoint_url: str | None) -> None:
    """Host the board over HTTP with the cloud board's own API, e.g. on an event laptop.

    Racers push to it with `--endpoint http://HOST:PORT`. Ctrl-C stops it; every push that was
    answered is saved.
    """
    from drboard_functions.service import LeaderboardService

    from .serve import BoardServer

    with edge():
        if endpoint_url and not table:
            raise click.UsageError("--endpoint-url goes with --table")
        if table:
            import boto3
            from drboard_functions.stores.dynamodb import DynamoDbStore

            client = boto3.client("dynamodb", endpoint_url=endpoint_url)
            service = LeaderboardService(DynamoDbStore(table, client=client))
            where = f"DynamoDB table {table}" + (f" at {endpoint_url}" if endpoint_url else "")
        else:
            service = LeaderboardService(local_board_store(ctx.db))
            where = str(ctx.db)
        server = BoardServer((host, port), service)
        bound_host, bound_port = str(server.server_address[0]), int(server.server_address[1])
        out.print(f"Serving {where} on http://{bound_host}:{bound_port}  (Ctrl-C to stop)",
                  soft_wrap=True)
        out.file.flush()
        signal.signal(signal.SIGTERM, _interrupt)
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            out.print("Stopping…")
        finally:
            server.server_close()


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def local_board_store(db: Path) -> Any:
    from drboard_functions.stores.sqlite import SqliteStore

    return SqliteStore(db)


def main() -> None:  # pragma: no cover
    cli()
