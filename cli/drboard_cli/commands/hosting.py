"""`drboard serve`: the board over HTTP, e.g. on an event laptop; `drboard joins`: its join code
and the racers who joined with it."""

from __future__ import annotations

import gc
import signal
import threading
from pathlib import Path
from typing import TYPE_CHECKING
from urllib.parse import quote

import click

from ..main import FAILURE, Context, edge, fail, interrupt, out, pass_context

if TYPE_CHECKING:
    from ..joins import JoinDesk


def desk_path(db: Path) -> Path:
    """Where `serve` keeps the join code and the joined racers: beside the board's file."""
    return db.with_name(db.stem + ".joined.sqlite")


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True,
              help="The address to listen on; 0.0.0.0 lets racers on your network push.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True,
              help="The port to listen on; 0 picks a free one.")
@click.option("--table", help="Serve a DynamoDB table instead of the embedded board.")
@click.option("--endpoint-url", metavar="URL",
              help="With --table: the DynamoDB endpoint, e.g. DynamoDB Local's http://127.0.0.1:8001.")
@click.option("--board", "board_id", metavar="BOARD",
              help="The night's board: its big-screen address and push command are printed "
                   "(and a word when it is not there yet).")
@click.option("--max-joins", type=click.IntRange(1, 10_000), default=100, show_default=True,
              help="How many racers one join code may join; then rotate it (`drboard joins rotate`).")
@click.option("--token-hours", type=click.FloatRange(0.1, 24 * 30), default=24, show_default=True,
              help="How long a racer's join lasts; joining again with the code renews it.")
@click.option("--new-code", is_flag=True, help="Rotate the join code before serving.")
@click.option("--log-requests", is_flag=True, help="Also log every HTTP request, one plain line each.")
@pass_context
def serve(ctx: Context, host: str, port: int, table: str | None, endpoint_url: str | None,
          board_id: str | None, max_joins: int, token_hours: float, new_code: bool,
          log_requests: bool) -> None:
    """Host the board over HTTP with the cloud board's own API, e.g. on an event laptop.

    It prints the board's network address, the big screen's, and the join command racers type
    (`drboard join CODE --endpoint URL`, also on the big screen). The code stays the same for
    the night, across restarts, until you rotate it (`drboard joins rotate`, or --new-code).
    Racers then push as the alias their first push claims. The organiser commands (`drboard
    board ...`, `season ...`, `audit`, `export`, `import`, `joins`) are answered only on this
    machine itself.
    The log says who pushed which model, its time and rank, and every refusal. Ctrl-C stops it;
    every push that was answered is saved.
    """
    from drboard_functions.board_ids import made_by_a_push
    from drboard_functions.notify.notifier import NoticeWorker
    from drboard_functions.services import dynamodb_service, sqlite_service

    from ..joins import JoinDesk
    from ..serve import BoardServer

    with edge():
        if endpoint_url and not table:
            raise click.UsageError("--endpoint-url goes with --table")
        if table:
            service = dynamodb_service(table, endpoint_url=endpoint_url)
            where = f"DynamoDB table {table}" + (f" at {endpoint_url}" if endpoint_url else "")
        else:
            service = sqlite_service(ctx.db)
            where = str(ctx.db)
        desk = JoinDesk(desk_path(ctx.db), max_joins=max_joins, token_hours=token_hours)
        if new_code:
            desk.rotate()
        server = BoardServer((host, port), service, desk, log_requests=log_requests)
        bound_host, bound_port = str(server.server_address[0]), int(server.server_address[1])
        url = server.public_url
        notices = NoticeWorker(service, url).start()  # the chat's announcements, in the background
        out().print(f"Serving {where} on {url}  (listening on {bound_host}:{bound_port}; Ctrl-C "
                    "to stop)", soft_wrap=True, highlight=False)
        boards = [board_id] if board_id else [b.board_id for b in service.boards()][:5]
        out().print(f"  Board pages:  {url}/", soft_wrap=True, highlight=False)
        for shown in boards or ["BOARD"]:
            out().print(f"  Big screen:   {url}/boards/{quote(shown, safe='')}/view?screen=1",
                        soft_wrap=True, highlight=False)
        if board_id and service.board_version(board_id) is None and not made_by_a_push(board_id):
            out().print(f"  No board {board_id!r} here yet: racers' pushes to it are refused until "
                        f"you create it (`drboard board create {board_id} --track TRACK --title "
                        "TITLE`).", style="yellow", soft_wrap=True, highlight=False)
        push = "drboard push ./my-model" + (f" --board {board_id}" if board_id else "")
        stop = threading.Event()
        announcer = threading.Thread(target=_announce_codes, args=(desk, url, push, stop), daemon=True)
        announcer.start()
        signal.signal(signal.SIGTERM, interrupt)
        # What is loaded and built by now (modules, schemas, resolvers) lives as long as the
        # server: kept out of the cycle collector's way, which would otherwise walk all of it
        # again and again as requests allocate (a tenth of a push's time).
        gc.collect()
        gc.freeze()
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            out().print("Stopping…")
        finally:
            stop.set()
            server.server_close()
            notices.stop()
            desk.close()


def _announce_codes(desk: JoinDesk, url: str, push: str, stop: threading.Event) -> None:
    """Print how racers join, and again whenever the code is rotated."""
    shown = None
    while True:
        code = desk.current_code()
        if code.code != shown:
            said = "Racers join with" if shown is None else "New join code; racers join with"
            out().print(f"  {said}:  [bold]drboard join {code.code} --endpoint {url}[/]  then  "
                        f"{push}\n  (the code stays valid, across restarts, until `drboard joins "
                        f"rotate`; it has joined {code.joins} of {code.max_joins} racers)",
                        soft_wrap=True, highlight=False)
            out().file.flush()
            shown = code.code
        if stop.wait(2.0):
            return


def _desk(ctx: Context) -> JoinDesk:
    from ..joins import JoinDesk

    return JoinDesk(desk_path(ctx.db))


@click.group()
def joins() -> None:
    """Organisers: the join code of `drboard serve` and the racers who joined with it.

    These work on the serving laptop, on the board file `serve` uses (give the same --db); a
    running `serve` takes a change at its next request.
    """


@joins.command(name="list")
@pass_context
def list_joins(ctx: Context) -> None:
    """The join code and every racer who joined with a code: alias, address, expiry."""
    from drboard_functions.display import when
    from rich.table import Table

    with edge():
        desk = _desk(ctx)
        try:
            code, joined = desk.current_code(), desk.joined()
        finally:
            desk.close()
        out().print(f"Join code {code.code}: {code.joins} of {code.max_joins} joins used (the "
                    "cap is `serve --max-joins`).", soft_wrap=True)
        table = Table(title="Racers who joined", header_style="bold")
        for name in ("Alias", "Sign-in", "From", "Joined", "Until"):
            table.add_column(name, overflow="fold")
        for racer in joined:
            until = "revoked" if racer.revoked else when(racer.expires_at)
            table.add_row(racer.alias or "(no push yet)", racer.principal, racer.client or "—",
                          when(racer.joined_at), until)
        out().print(table)


@joins.command()
@pass_context
def rotate(ctx: Context) -> None:
    """A new join code: the old one joins no one from now on; who joined stays joined."""
    with edge():
        desk = _desk(ctx)
        try:
            code = desk.rotate()
        finally:
            desk.close()
        out().print(f"New join code: [bold]{code.code}[/] (the big screen shows it at its next "
                    "refresh).", soft_wrap=True)


@joins.command()
@click.argument("who", required=False)
@click.option("--all", "everyone", is_flag=True, help="Revoke every racer's join.")
@pass_context
def revoke(ctx: Context, who: str | None, everyone: bool) -> None:
    """Revoke a racer's join: WHO is the alias they push as, or their `join:` sign-in.

    Their token signs no one in from then on and cannot be renewed; rotate the code too if
    they should not join again (`drboard joins rotate`).
    """
    with edge():
        if bool(who) == everyone:
            raise click.UsageError("give WHO (an alias or a join: sign-in) or --all")
        desk = _desk(ctx)
        try:
            revoked = desk.revoke(None if everyone else who)
        finally:
            desk.close()
        if not revoked:
            fail(f"no joined racer is {who!r} (see `drboard joins list`)", FAILURE)
        for racer in revoked:
            out().print(f"Revoked {racer.alias or 'a racer with no push yet'} ({racer.principal}).",
                        soft_wrap=True)
