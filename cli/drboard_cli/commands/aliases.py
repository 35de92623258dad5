"""Organisers' hand on racers' aliases: `drboard aliases ...` and `drboard invite`."""

from __future__ import annotations

from pathlib import Path
from typing import IO

import click

from ..main import BAD_INPUT, FAILURE, Context, edge, err, fail, out, pass_context
from ..target import every_page

PAGE = 500
FORMAT_HELP = "table for people, json for scripts."


@click.group(name="aliases")
def aliases_group() -> None:
    """Organisers: reserve racers' aliases, give one to a sign-in, release one.

    An alias belongs to the sign-in that holds it. A racer's first stored push claims an alias no
    one holds; an alias reserved here, or one with results but no sign-in (pushed by an
    organiser, imported, pushed before sign-ins), only an organiser gives out. Every change is in
    `drboard aliases audit`.
    """


@aliases_group.command(name="list")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def aliases_list(ctx: Context, fmt: str) -> None:
    """Every alias held or reserved, and by whom."""
    from .. import render

    with edge():
        views = [view for page in every_page(lambda cursor: ctx.board.aliases(PAGE, cursor))
                 for view in page.aliases]
        if fmt == "json":
            out().print_json(data=[view.model_dump(mode="json") for view in views])
        else:
            out().print(render.alias_table(views))


@aliases_group.command(name="reserve")
@click.argument("names", metavar="ALIAS...", nargs=-1)
@click.option("--file", "source", type=click.File("r", encoding="utf-8"),
              help="Also each alias of this file, one a line (`-` for standard input).")
@pass_context
def aliases_reserve(ctx: Context, names: tuple[str, ...], source: IO[str] | None) -> None:
    """Keep each ALIAS for its racer (a season's racers in one go).

    No one can claim a reserved alias: give it to the racer's sign-in with `drboard aliases
    assign`, or invite them with `drboard invite`. An alias someone holds already stays theirs.
    Every alias is checked first: one a racer may not take reserves none.
    """
    from drboard_functions.errors import InvalidQuery
    from drboard_functions.service.pushing import valid_alias

    from .. import render

    wanted = [*names, *(line.strip() for line in (source or []) if line.strip())]
    if not wanted:
        raise click.UsageError("give at least one ALIAS (or --file)")
    for name in wanted:
        try:
            valid_alias(name)
        except InvalidQuery as error:
            fail(f"{name!r}: {error.message}", BAD_INPUT)
    with edge():
        views = [ctx.board.assign_alias(name, None, False) for name in wanted]
        out().print(render.alias_table(views, title="Reserved aliases"))


@aliases_group.command(name="assign")
@click.argument("name", metavar="ALIAS")
@click.argument("principal")
@click.option("--replace", is_flag=True, help="Take the alias from the sign-in that holds it.")
@pass_context
def aliases_assign(ctx: Context, name: str, principal: str, replace: bool) -> None:
    """Give ALIAS to the sign-in PRINCIPAL (as `drboard whoami` shows it, e.g. `cognito:…`, `join:…`).

    A reservation gives way; an alias another sign-in holds moves only with --replace. The sign-in
    pushes as ALIAS from then on (any alias it held before is freed).
    """
    from .. import render

    with edge():
        out().print(render.alias_table([ctx.board.assign_alias(name, principal, replace)],
                                        title="Alias given"))


@aliases_group.command(name="release")
@click.argument("name", metavar="ALIAS")
@pass_context
def aliases_release(ctx: Context, name: str) -> None:
    """Free ALIAS from its sign-in or reservation."""
    from .. import render

    with edge():
        out().print(render.alias_table([ctx.board.release_alias(name)], title="Released"))


@aliases_group.command(name="audit")
@click.option("--format", "fmt", type=click.Choice(["table", "json"]), default="table",
              show_default=True, help=FORMAT_HELP)
@pass_context
def aliases_audit(ctx: Context, fmt: str) -> None:
    """Every reservation, assignment and release of an alias: who, when, what."""
    from .. import render

    with edge():
        events = [event for page in every_page(lambda cursor: ctx.board.alias_audit(cursor, PAGE))
                  for event in page.events]
        if fmt == "json":
            out().print_json(data=[event.model_dump(mode="json") for event in events])
        else:
            out().print(render.audit_table("aliases", events))


@click.command()
@click.argument("source", metavar="FILE", type=click.Path(exists=True, dir_okay=False, allow_dash=True,
                                                           path_type=Path))
@click.option("--region", help="The user pool's AWS region (default: the one the board names).")
@pass_context
def invite(ctx: Context, source: Path, region: str | None) -> None:
    """Invite racers to a deployed board: a user each, their alias kept for them.

    FILE (or `-`) is CSV, one racer a line: `email,alias` (a header line `email,alias` is fine).
    Each racer becomes a user of the board's user pool (Cognito e-mails them a temporary password;
    their user name is their e-mail) and their alias is given to that sign-in. Every line is
    checked first: a bad one invites no one. Run again, it changes nothing done already. Needs the
    organiser's AWS credentials; a summary says what was done for each racer.
    """
    import sys

    import boto3

    from .. import invite as invites
    from .. import render
    from ..login import require_cognito, sign_in_settings

    name = "-" if str(source) == "-" else str(source)
    try:
        if name == "-":
            racers = invites.read_racers("standard input", sys.stdin)
        else:
            with source.open(encoding="utf-8") as handle:
                racers = invites.read_racers(name, handle)
    except (invites.BadRacerList, UnicodeDecodeError) as error:
        fail(str(error), BAD_INPUT)
    with edge():
        if not ctx.endpoint:
            raise click.UsageError("invite is for a deployed board: give it with --endpoint URL "
                                   "(or `drboard configure --stack-name NAME`)")
        settings = require_cognito(sign_in_settings(str(ctx.endpoint)), str(ctx.endpoint))
        cognito = boto3.client("cognito-idp", region_name=region or settings.region)
        done = invites.invite(racers, ctx.board, cognito, str(settings.user_pool_id))
        out().print(render.invite_table(done))
        line = render.invite_summary(done)
        (out() if all(result.ok for result in done) else err()).print(line, soft_wrap=True)
    if not all(result.ok for result in done):
        sys.exit(FAILURE)
