"""`drboard serve`: the board over HTTP, e.g. on an event laptop."""

from __future__ import annotations

import signal
import threading
from datetime import UTC, datetime
from typing import Any

import click

from ..main import Context, edge, interrupt, out, pass_context


@click.command()
@click.option("--host", default="127.0.0.1", show_default=True,
              help="The address to listen on; 0.0.0.0 lets racers on your network push.")
@click.option("--port", type=click.IntRange(0, 65535), default=8000, show_default=True,
              help="The port to listen on; 0 picks a free one.")
@click.option("--table", help="Serve a DynamoDB table instead of the embedded board.")
@click.option("--endpoint-url", metavar="URL",
              help="With --table: the DynamoDB endpoint, e.g. DynamoDB Local's http://127.0.0.1:8001.")
@click.option("--code-minutes", type=click.IntRange(1, 7 * 24 * 60), default=60, show_default=True,
              help="How long each join code is good for; a new one is printed when it runs out.")
@pass_context
def serve(ctx: Context, host: str, port: int, table: str | None, endpoint_url: str | None,
          code_minutes: int) -> None:
    """Host the board over HTTP with the cloud board's own API, e.g. on an event laptop.

    Racers on your network join with the code it prints (`drboard join CODE --endpoint
    http://HOST:PORT`), then push as the alias their first push claims. The organiser commands
    (`drboard board ...`, `audit`, `export`, `import`) are answered only on this machine itself.
    Ctrl-C stops it; every push that was answered is saved.
    """
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
        desk = JoinDesk(ctx.db.with_name(ctx.db.stem + ".joined.sqlite"), code_minutes)
        server = BoardServer((host, port), service, desk)
        bound_host, bound_port = str(server.server_address[0]), int(server.server_address[1])
        url = f"http://{_reachable(bound_host)}:{bound_port}"
        out().print(f"Serving {where} on http://{bound_host}:{bound_port}  (Ctrl-C to stop)",
                    soft_wrap=True)
        notices = NoticeWorker(service, url).start()  # the chat's announcements, in the background
        stop = threading.Event()
        announcer = threading.Thread(target=_announce_codes, args=(desk, url, stop), daemon=True)
        announcer.start()
        signal.signal(signal.SIGTERM, interrupt)
        try:
            server.serve_forever()
        except KeyboardInterrupt:
            out().print("Stopping…")
        finally:
            stop.set()
            server.server_close()
            notices.stop()
            desk.close()


def _announce_codes(desk: Any, url: str, stop: threading.Event) -> None:
    """Print the join code, and each new one when the last runs out."""
    shown = None
    while True:
        code = desk.current_code()
        if code != shown:
            out().print(f"Racers join with code [bold]{code.code}[/] (good until "
                        f"{code.expires_at:%H:%M} UTC): drboard join {code.code} --endpoint {url}",
                        soft_wrap=True, highlight=False)
            out().file.flush()
            shown = code
        wait = (code.expires_at - datetime.now(UTC)).total_seconds()
        if stop.wait(max(1.0, min(wait, 60.0))):
            return


def _reachable(host: str) -> str:
    """The address racers reach this computer at: for 0.0.0.0, its own on the network."""
    if host not in ("0.0.0.0", "::"):
        return f"[{host}]" if ":" in host else host
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("10.254.254.254", 1))  # no packet is sent: this only picks a route
            return str(probe.getsockname()[0])
        except OSError:
            return socket.gethostname()

