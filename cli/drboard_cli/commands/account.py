"""Who you are and which board you use: alias, configure, login, logout, whoami and join."""

from __future__ import annotations

from typing import Any

import click

from ..main import Context, edge, err, out, pass_context


def _endpoint(ctx: Context, command: str) -> str:
    if not ctx.endpoint:
        raise click.UsageError(f"give the board: drboard --endpoint URL {command} (or save it "
                               "with `drboard configure`)")
    return str(ctx.endpoint).rstrip("/")


@click.command()
@click.argument("name", required=False)
@pass_context
def alias(ctx: Context, name: str | None) -> None:
    """Claim NAME as the racer alias you push as, or show the one you hold.

    An alias is claimed once, by one sign-in; your first push claims its racer's alias too.
    """
    from .. import render

    with edge():
        me = ctx.board.claim_alias(name) if name else ctx.board.me()
        out().print(render.me_line(me), soft_wrap=True)


@click.command()
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
    from .. import config

    with edge():
        if sum(map(bool, (stack_name, endpoint_url, use_local))) > 1:
            raise click.UsageError("give one of --stack-name, --endpoint or --local")
        changes: dict[str, Any] = {}
        if stack_name:
            from ..cloud import stack_endpoint

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
        out().print(f"Board: {target}", soft_wrap=True)
        if settings.get("stack_name"):
            out().print(f"Stack: {settings['stack_name']}")
        if settings.get("racer"):
            out().print(f"Racer: {settings['racer']}")
        out().print(f"Saved in {config.settings_path()}", style="dim", soft_wrap=True)


@click.command()
@click.option("--password", "use_password", is_flag=True,
              help="Sign in with your user name and password here, with no browser.")
@click.option("--username", help="With --password: your user name (asked for otherwise).")
@click.option("--no-browser", is_flag=True,
              help="For a machine with no browser: print the sign-in address, sign in on any "
                   "device, and paste back the address the browser shows then (or its code).")
@pass_context
def login(ctx: Context, use_password: bool, username: str | None, no_browser: bool) -> None:
    """Sign in to a deployed board, as a racer or an organiser.

    Opens the board's sign-in page in your browser and waits for it to send you back (to
    http://localhost:8765/callback). With --no-browser (a headless machine), prints the
    address: sign in on any device, then paste here the address the browser ends on (it does
    not load, but holds the code) or the code alone. With --password, asks for your user name
    and password here instead (an invited racer's temporary password is replaced by a new one).
    The token is saved for that board in your user config folder, readable by you only, and renewed before it
    expires; `drboard logout` forgets it.
    """
    from .. import login as signing_in

    with edge():
        endpoint = _endpoint(ctx, "login")
        settings = signing_in.require_cognito(signing_in.sign_in_settings(endpoint), endpoint)
        if use_password:
            name = username or click.prompt("User name")
            password = click.prompt("Password", hide_input=True)
            token = signing_in.login_with_password(
                endpoint, settings, name, password,
                new_password=lambda: click.prompt("Choose a new password", hide_input=True,
                                                  confirmation_prompt=True))
        elif no_browser:
            def show_address(url: str) -> None:
                err().print(f"Open this address on any device and sign in:\n{url}\n", soft_wrap=True)

            token = signing_in.login_with_pasted_code(
                endpoint, settings, show_address,
                ask=lambda: click.prompt("Then paste the address your browser ends on (or its code)"))
        else:
            def show(url: str) -> None:
                err().print(f"Opening your browser to sign in (or open {url})", soft_wrap=True)

            token = signing_in.login_in_browser(endpoint, settings, show)
        out().print(f"Signed in to {endpoint} as {token.username or 'you'}.", soft_wrap=True)


@click.command()
@pass_context
def logout(ctx: Context) -> None:
    """Forget your sign-in to the board (and revoke it, on a deployed board)."""
    from .. import login as signing_in

    with edge():
        endpoint = _endpoint(ctx, "logout")
        forgot = signing_in.logout(endpoint)
        out().print(f"Signed out of {endpoint}." if forgot else f"You were not signed in to {endpoint}.",
                    soft_wrap=True)


@click.command()
@pass_context
def whoami(ctx: Context) -> None:
    """Who the board takes you for: your sign-in, whether you organise, and your racer alias."""
    from .. import render

    with edge():
        out().print(render.me_line(ctx.board.me()), soft_wrap=True)


@click.command()
@click.argument("code")
@click.option("--endpoint", "endpoint_url", metavar="URL",
              help="The board to join, as `drboard serve` shows it (the same as the global "
                   "`drboard --endpoint URL join CODE`).")
@pass_context
def join(ctx: Context, code: str, endpoint_url: str | None) -> None:
    """Sign in to a `drboard serve` board with the join code its organiser shows.

    Type it as `drboard serve` and the big screen show it: `drboard join CODE --endpoint URL`.
    The token the board answers is saved for that board in your user config folder, readable
    by you only, and the board becomes the one your commands use (`drboard push ./my-model`
    pushes there; `drboard configure --local` goes back to your own board). Joining again
    renews an expired token and keeps your racer alias.
    """
    from .. import config, tokens
    from ..remote import HttpBoard

    with edge():
        if endpoint_url and not endpoint_url.startswith(("http://", "https://")):
            raise click.UsageError("--endpoint must be an http:// URL, as `drboard serve` shows it")
        board = HttpBoard(endpoint_url or _endpoint(ctx, "join CODE"))
        held = tokens.load(board.endpoint)
        joined = board.join(code, renewing=held.access_token if held and held.kind == "join" else None)
        tokens.save(board.endpoint, tokens.SavedToken(kind="join", access_token=joined.token,
                                                      username=joined.principal,
                                                      expires_at=joined.expires_at))
        config.save_settings(endpoint=board.endpoint, stack_name=None)
        again = "Renewed your join to" if joined.renewed else "Joined"
        out().print(f"{again} {board.endpoint} as {joined.principal}; it is now the board your "
                    "commands use. Push with `drboard push ./my-model`: your first push claims "
                    "your racer alias (or claim it now with `drboard alias NAME`).", soft_wrap=True)
