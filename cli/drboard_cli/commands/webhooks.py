"""`drboard board webhook`: organisers' chat webhooks of a board (add, list, remove, test)."""

from __future__ import annotations

import click

from ..main import FAILURE, Context, edge, fail, out, pass_context

EVENTS = ("new-leader", "top-3", "personal-best", "board-open", "board-close")


@click.group(name="webhook")
def webhook_group() -> None:
    """Organisers: announce a board in the club's chat (Discord, Slack or any JSON endpoint).

    A new leader, a racer entering the top 3, a personal best, the board opening and closing
    with its podium. The webhook's URL is a secret: the board keeps it and shows only its host
    and last four characters. A failing webhook never holds a push: `list` shows its last error.
    """


@webhook_group.command(name="add")
@click.argument("board_id", metavar="BOARD")
@click.option("--kind", type=click.Choice(["discord", "slack", "json"]), required=True,
              help="The chat service: its incoming webhook, or any endpoint taking a JSON POST.")
@click.option("--url", help="The webhook's URL (asked for, unechoed, when not given: it stays out "
                            "of your shell's history).")
@click.option("--event", "events", multiple=True, type=click.Choice(EVENTS),
              help="An event to announce; give it again for more (default: every event).")
@pass_context
def webhook_add(ctx: Context, board_id: str, kind: str, url: str | None, events: tuple[str, ...]) -> None:
    """Add a chat webhook to BOARD: its announcements go there from now on."""
    from drboard_functions.models.notices import WebhookSpec
    from pydantic import ValidationError

    with edge():
        secret = url or click.prompt("Webhook URL", hide_input=True)
        try:
            spec = WebhookSpec.model_validate({"kind": kind, "url": secret, **(
                {"events": list(events)} if events else {})})
        except ValidationError as error:
            problem = error.errors()[0]
            raise click.BadParameter(str(problem["msg"]).removeprefix("Value error, "),
                                     param_hint="'--url'") from None
        view = ctx.board.add_webhook(board_id, spec)
        out().print(f"Added {view.kind} webhook {view.webhook_id} ({view.url}) to {board_id}: "
                    f"{', '.join(view.events)}. Try it: drboard board webhook test {board_id} "
                    f"{view.webhook_id}", soft_wrap=True, highlight=False)


@webhook_group.command(name="list")
@click.argument("board_id", metavar="BOARD")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table", show_default=True,
              help="table for people, json for scripts.")
@pass_context
def webhook_list(ctx: Context, board_id: str, fmt: str) -> None:
    """BOARD's webhooks: kind, URL (cut short), events, last delivery and last error."""
    from drboard_functions.display import when
    from rich.table import Table

    with edge():
        found = ctx.board.webhooks(board_id)
        if fmt == "json":
            click.echo(found.model_dump_json(indent=2))
            return
        if not found.webhooks:
            out().print(f"{board_id} has no webhooks: add one with `drboard board webhook add`.")
            return
        table = Table(title=f"Webhooks of {board_id}", header_style="bold")
        for name in ("Id", "Kind", "URL", "Events", "Last sent", "Last error"):
            table.add_column(name, overflow="fold")
        for hook in found.webhooks:
            error = f"{when(hook.last_error_at)}: {hook.last_error}" if hook.last_error else "—"
            table.add_row(hook.webhook_id, hook.kind, hook.url, ", ".join(hook.events),
                          when(hook.last_sent_at), error)
        out().print(table)


@webhook_group.command(name="remove")
@click.argument("board_id", metavar="BOARD")
@click.argument("webhook_id", metavar="ID")
@pass_context
def webhook_remove(ctx: Context, board_id: str, webhook_id: str) -> None:
    """Remove webhook ID from BOARD: nothing more is posted to it."""
    with edge():
        view = ctx.board.remove_webhook(board_id, webhook_id)
        out().print(f"Removed {view.kind} webhook {view.webhook_id} ({view.url}) from {board_id}.",
                    soft_wrap=True, highlight=False)


@webhook_group.command(name="test")
@click.argument("board_id", metavar="BOARD")
@click.argument("webhook_id", metavar="ID")
@pass_context
def webhook_test(ctx: Context, board_id: str, webhook_id: str) -> None:
    """Post a test message to webhook ID of BOARD now, and say whether the service took it."""
    with edge():
        delivery = ctx.board.test_webhook(board_id, webhook_id)
        if not delivery.sent:
            fail(f"the test message to {delivery.webhook.url} failed: {delivery.error}", FAILURE)
        out().print(f"Sent a test message to {delivery.webhook.kind} webhook {webhook_id} "
                    f"({delivery.webhook.url}).", soft_wrap=True, highlight=False)
