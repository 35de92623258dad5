"""`drboard invite`: racers of a deployed board, from a list of e-mails and aliases, in one go.

Each racer becomes a user of the board's Cognito user pool (Cognito e-mails them a temporary
password; the user name is their e-mail), and their alias is given to that sign-in on the board,
so no one else can take it. Run again, it changes nothing that is done: a user that exists is
kept (not invited twice) and an alias already theirs stays. An alias another sign-in holds is
left to it and reported. The pool is the one the board names (``/.well-known/drboard.json``);
the calls go with the organiser's AWS credentials (boto3): the AWS CLI is not needed.
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from typing import IO, Any, Literal

from drboard_functions.errors import AliasTaken, DomainError, InvalidQuery
from drboard_functions.service.pushing import valid_alias

from .target import BoardClient

MAX_RACERS = 1000


class BadRacerList(ValueError):
    """A line of the racer list is not an e-mail and an alias: nothing was done."""


@dataclass(frozen=True)
class Racer:
    line: int
    email: str
    alias: str


@dataclass
class Invited:
    racer: Racer
    user: Literal["created", "existed", "failed"] = "failed"
    alias: Literal["theirs", "held", "failed"] = "failed"
    problem: str = ""

    @property
    def ok(self) -> bool:
        return self.user != "failed" and self.alias == "theirs"


def read_racers(name: str, handle: IO[str]) -> list[Racer]:
    """The racers of a list: CSV lines ``email,alias`` (a header line naming ``email`` is
    skipped; blank lines and lines starting with ``#`` too). Every line is checked first."""
    racers: list[Racer] = []
    seen: dict[str, int] = {}
    for number, row in enumerate(csv.reader(io.StringIO(handle.read())), start=1):
        cells = [cell.strip() for cell in row]
        if not any(cells) or cells[0].startswith("#"):
            continue
        if number == 1 and cells[0].lower() in ("email", "e-mail"):
            continue
        if len(cells) != 2 or not all(cells):
            raise BadRacerList(f"{name}:{number}: give an e-mail and an alias, e.g. "
                               "ada@example.org,Ada")
        email, alias = cells
        if "@" not in email.strip("@") or any(ch.isspace() for ch in email):
            raise BadRacerList(f"{name}:{number}: email: {email!r} is not an e-mail address")
        try:
            alias = valid_alias(alias)
        except InvalidQuery as error:
            raise BadRacerList(f"{name}:{number}: alias: {error.message}") from None
        key = email.casefold()
        if key in seen:
            raise BadRacerList(f"{name}:{number}: email: {email} is on line {seen[key]} too")
        seen[key] = number
        racers.append(Racer(number, email, alias))
    if not racers:
        raise BadRacerList(f"{name}: no racers in it (one `email,alias` a line)")
    if len(racers) > MAX_RACERS:
        raise BadRacerList(f"{name}: {len(racers)} racers, over the {MAX_RACERS} one list may hold")
    return racers


def invite(racers: list[Racer], board: BoardClient, cognito: Any, user_pool_id: str) -> list[Invited]:
    """Create each racer's user (unless it exists) and give their alias to its sign-in."""
    done = []
    for racer in racers:
        result = Invited(racer)
        done.append(result)
        try:
            sub, result.user = _user(cognito, user_pool_id, racer.email)
        except cognito.exceptions.ClientError as error:
            result.problem = f"the user pool refused it: {error.response['Error'].get('Message', error)}"
            continue
        try:
            board.assign_alias(racer.alias, f"cognito:{sub}", False)
        except AliasTaken as error:
            result.alias, result.problem = "held", error.message
            continue
        except DomainError as error:
            result.problem = error.message
            continue
        result.alias = "theirs"
    return done


def _user(cognito: Any, user_pool_id: str, email: str) -> tuple[str, Literal["created", "existed"]]:
    """The user's ``sub``, creating the user (Cognito e-mails the invitation) unless it exists."""
    try:
        answer = cognito.admin_create_user(
            UserPoolId=user_pool_id, Username=email, DesiredDeliveryMediums=["EMAIL"],
            UserAttributes=[{"Name": "email", "Value": email},
                            {"Name": "email_verified", "Value": "true"}])
        return _sub(answer["User"].get("Attributes", [])), "created"
    except cognito.exceptions.UsernameExistsException:
        user = cognito.admin_get_user(UserPoolId=user_pool_id, Username=email)
        return _sub(user.get("UserAttributes", [])), "existed"


def _sub(attributes: list[dict[str, str]]) -> str:
    return next(attribute["Value"] for attribute in attributes if attribute["Name"] == "sub")
