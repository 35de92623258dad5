"""`drboard board webhook` and `drboard season webhook`: organisers' chat webhooks of a board, or
of a season (which hear its rounds' and its final's events): add, list, remove, test."""

from __future__ import annotations

from typing import TYPE_CHECKING

import click

from ..main import FAILURE, Context, edge, fail, out, pass_context

if TYPE_CHECKING:
    from drboard_functions.models.notices import TargetKind

EVENTS = ("new-leader", "top-3", "personal-best", "board-open", "board-close")
_GROUP_HELP = {
    "board": """Organisers: announce a board in the club's chat (Discord, Slack or any JSON endpoint).

    A new leader, a racer entering the top 3, a personal best, the board opening and closing
    with its podium. The webhook's URL is a secret: the board keeps it and shows only its host
    and last four characters. A failing webhook never holds a push: `list` shows its last error.
    """,
    "season": """Organisers: announce every round of a season in the club's chat (Discord, Slack, JSON).

    The events of each round's board and of the final's, as a board's own webhooks hear them:
    a new leader, a racer entering the top 3, a personal best, a round opening and closing with
    its podium. The URL is a secret, shown only cut short; `list` shows a failing webhook's error.
    """,
}


def webhook_commands(kind: TargetKind) -> click.Group:
    """The ``webhook`` group of ``drboard board`` (``kind="board"``) or ``drboard season``."""
    what = kind.upper()  # the argument's name: BOARD, SEASON
    heard = "its announcements" if kind == "board" else "its rounds' announcements"
    group = click.Group(name="webhook", help=_GROUP_HELP[kind])

    @group.command(name="add", help=f"Add a chat webhook to {what}: {heard} go there from now on.")
    @click.argument("target_id", metavar=what)
    @click.option("--kind", "service", type=click.Choice(["discord", "slack", "json"]), required=True,
                  help="The chat service: its incoming webhook, or any endpoint taking a JSON POST.")
    @click.option("--url", help="The webhook's URL (asked for, unechoed, when not given: it stays "
                                "out of your shell's history).")
    @click.option("--event", "events", multiple=True, type=click.Choice(EVENTS),
                  help="An event to announce; give it again for more (default: every event).")
    @pass_context
    def add(ctx: Context, target_id: str, service: str, url: str | None, events: tuple[str, ...]) -> None:
        from drboard_functions.models.notices import WebhookSpec
        from pydantic import ValidationError

        with edge():
            secret = url or click.prompt("Webhook URL", hide_input=True)
            try:
                spec = WebhookSpec.model_validate({"kind": service, "url": secret, **(
                    {"events": list(events)} if events else {})})
            except ValidationError as error:
                problem = error.errors()[0]
                raise click.BadParameter(str(problem["msg"]).removeprefix("Value error, "),
                                         param_hint="'--url'") from None
            view = ctx.board.add_webhook(target_id, spec, kind=kind)
            out().print(f"Added {view.kind} webhook {view.webhook_id} ({view.url}) to {target_id}: "
                        f"{', '.join(view.events)}. Try it: drboard {kind} webhook test {target_id} "
                        f"{view.webhook_id}", soft_wrap=True, highlight=False)

    @group.command(name="list", help=f"{what}'s webhooks: kind, URL (cut short), events, last "
                                     "delivery and last error.")
    @click.argument("target_id", metavar=what)
    @click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
                  show_default=True, help="table for people, json for scripts.")
    @pass_context
    def listed(ctx: Context, target_id: str, fmt: str) -> None:
        from drboard_functions.display import when
        from rich.table import Table

        with edge():
            found = ctx.board.webhooks(target_id, kind=kind)
            if fmt == "json":
                click.echo(found.model_dump_json(indent=2))
                return
            if not found.webhooks:
                out().print(f"{target_id} has no webhooks: add one with `drboard {kind} webhook add`.")
                return
            table = Table(title=f"Webhooks of {target_id}", header_style="bold")
            for name in ("Id", "Kind", "URL", "Events", "Last sent", "Last error"):
                table.add_column(name, overflow="fold")
            for hook in found.webhooks:
                error = f"{when(hook.last_error_at)}: {hook.last_error}" if hook.last_error else "—"
                table.add_row(hook.webhook_id, hook.kind, hook.url, ", ".join(hook.events),
                              when(hook.last_sent_at), error)
            out().print(table)

    @group.command(name="remove", help=f"Remove webhook ID from {what}: nothing more is posted to it.")
    @click.argument("target_id", metavar=what)
    @click.argument("webhook_id", metavar="ID")
    @pass_context
    def remove(ctx: Context, target_id: str, webhook_id: str) -> None:
        with edge():
            view = ctx.board.remove_webhook(target_id, webhook_id, kind=kind)
            out().print(f"Removed {view.kind} webhook {view.webhook_id} ({view.url}) from {target_id}.",
                        soft_wrap=True, highlight=False)

    @group.command(name="test", help=f"Post a test message to webhook ID of {what} now, and say "
                                     "whether the service took it.")
    @click.argument("target_id", metavar=what)
    @click.argument("webhook_id", metavar="ID")
    @pass_context
    def test(ctx: Context, target_id: str, webhook_id: str) -> None:
        with edge():
            delivery = ctx.board.test_webhook(target_id, webhook_id, kind=kind)
            if not delivery.sent:
                fail(f"the test message to {delivery.webhook.url} failed: {delivery.error}", FAILURE)
            out().print(f"Sent a test message to {delivery.webhook.kind} webhook {webhook_id} "
                        f"({delivery.webhook.url}).", soft_wrap=True, highlight=False)

    return group


webhook_group = webhook_commands("board")
season_webhook_group = webhook_commands("season")
