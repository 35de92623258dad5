"""What an organiser types to manage a board, read into the service's BoardSpec and BoardChanges.

WHEN is an ISO 8601 moment with a time zone (``2026-12-01T18:00:00Z``, ``2026-12-01 19:00+01:00``)
or ``now``; DURATION is ``90s``, ``30m``, ``1h30m``, ``2d`` or plain seconds. In an update, ``none``
clears a time or a limit. A value that does not parse, or that the board's rules refuse, is a
usage error naming the option: nothing is sent.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any, Final, TypeVar

import click

if TYPE_CHECKING:  # the models load when a board is created or changed, not for --help
    from drboard_functions.models.requests import BoardChanges, BoardSpec
    from pydantic import BaseModel

M = TypeVar("M", bound="BaseModel")


class _Clear:
    """The value ``none`` stands for in an update: clear the time or the limit."""

    def __repr__(self) -> str:
        return "CLEAR"


CLEAR: Final = _Clear()

_DURATION = re.compile(r"(?:(\d+)d)?(?:(\d+)h)?(?:(\d+)m)?(?:(\d+)s)?")
_UNIT_SECONDS = (86_400, 3_600, 60, 1)


def parse_when(text: str, now: Callable[[], datetime] = lambda: datetime.now(UTC)) -> datetime:
    """``now`` or an ISO 8601 moment with a time zone, in UTC."""
    cleaned = text.strip()
    if cleaned.lower() == "now":
        return now().astimezone(UTC)
    try:
        moment = datetime.fromisoformat(cleaned)
    except ValueError:
        raise ValueError(f"{text!r} is not a time: give ISO 8601 with a time zone, e.g. "
                         "2026-12-01T18:00:00Z or 2026-12-01T19:00+01:00, or `now`") from None
    if moment.tzinfo is None:
        raise ValueError(f"{text!r} has no time zone: add one, e.g. {cleaned}Z for UTC "
                         f"or {cleaned}+01:00")
    return moment.astimezone(UTC)


def parse_duration(text: str) -> int:
    """``90s``, ``30m``, ``1h30m``, ``2d`` or plain seconds, as seconds."""
    cleaned = text.strip().lower().replace(" ", "")
    if cleaned.isdigit():
        return int(cleaned)
    match = _DURATION.fullmatch(cleaned)
    if not cleaned or match is None:
        raise ValueError(f"{text!r} is not a duration: give e.g. 90s, 30m, 1h30m, 2d "
                         "or plain seconds")
    return sum(int(amount) * unit for amount, unit in zip(match.groups(), _UNIT_SECONDS, strict=True)
               if amount)


if TYPE_CHECKING:  # click 8.5 makes ParamType generic; earlier versions do not subscript it
    _ParamType = click.ParamType[Any, Any]
else:
    _ParamType = click.ParamType


class _OptionType(_ParamType):
    """A click type over one of the parsers above; with ``clearable``, ``none`` gives CLEAR."""

    def __init__(self, clearable: bool) -> None:
        self.clearable = clearable

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if not isinstance(value, str):
            return value
        if self.clearable and value.strip().lower() == "none":
            return CLEAR
        try:
            return self.parse(value)
        except ValueError as error:
            self.fail(str(error), param, ctx)

    def parse(self, text: str) -> Any:
        raise NotImplementedError


class When(_OptionType):
    name = "when"

    def parse(self, text: str) -> datetime:
        return parse_when(text)


class Duration(_OptionType):
    name = "duration"

    def __init__(self, clearable: bool, longest_s: int) -> None:
        super().__init__(clearable)
        self.longest_s = longest_s

    def parse(self, text: str) -> int:
        from drboard_functions.display import duration

        total_s = parse_duration(text)
        if total_s > self.longest_s:
            raise ValueError(f"{text!r} is longer than the longest allowed, {duration(self.longest_s)}")
        return total_s


class Count(_OptionType):
    """A whole number from 1 up."""

    name = "count"

    def parse(self, text: str) -> int:
        if not text.strip().isdigit() or int(text) < 1:
            raise ValueError(f"{text!r} is not a whole number of 1 or more")
        return int(text)


class Requirement(_OptionType):
    """``CONDITION=VALUE``: an evaluation condition a board requires (see CONDITIONS)."""

    name = "condition"

    def parse(self, text: str) -> tuple[str, Any]:
        return parse_requirement(text)


#: The conditions a board can require, as typed, and the field each sets.
CONDITIONS = {"off-track-penalty": "off_track_penalty_s", "collision-penalty": "collision_penalty_s",
              "resets": "max_resets", "trials": "trials", "continuous": "continuous",
              "obstacles": "obstacles", "bots": "bots"}
_YES, _NO = {"yes", "true", "on", "1"}, {"no", "false", "off", "0"}


def parse_requirement(text: str) -> tuple[str, Any]:
    """``off-track-penalty=5`` (seconds, ``5s`` too), ``trials=3``, ``continuous=yes``."""
    name, _, value = text.partition("=")
    field = CONDITIONS.get(name.strip().lower())
    if field is None or not value.strip():
        raise ValueError(f"{text!r} is not CONDITION=VALUE; the conditions are "
                         + ", ".join(CONDITIONS))
    value = value.strip().lower()
    if field == "continuous":
        if value not in _YES | _NO:
            raise ValueError(f"{text!r}: continuous is yes or no")
        return field, value in _YES
    number = value.removesuffix("s") if field.endswith("_s") else value
    try:
        return field, float(number) if field.endswith("_s") else int(number)
    except ValueError:
        kind = "seconds" if field.endswith("_s") else "a whole number"
        raise ValueError(f"{text!r}: {name.strip()} takes {kind}") from None


BOARD_ID_RULE = "letters, digits, `_`, `-` and `.`, up to 64, starting with a letter or digit"

#: The option each field of a board comes from, to name it in an error.
OPTION_OF_FIELD = {
    "board_id": "ID", "title": "--title", "description": "--description", "track": "--track",
    "custom_track": "--custom-track", "clockwise": "--clockwise", "race_type": "--race-type",
    "method": "--method", "min_laps": "--min-laps", "opens_at": "--opens-at",
    "closes_at": "--closes-at", "cooldown_s": "--cooldown", "max_submissions": "--max-submissions",
    "flagged_runs": "--flagged-runs", "designs": "--designs", "conditions": "--require",
}
_FIELD_OF_OPTION = {
    "board_id": "board_id", "title": "title", "description": "description", "track": "track",
    "custom_track": "custom_track", "clockwise": "clockwise", "race_type": "race_type",
    "method": "method", "min_laps": "min_laps", "opens_at": "opens_at", "closes_at": "closes_at",
    "cooldown": "cooldown_s", "max_submissions": "max_submissions", "flagged_runs": "flagged_runs",
    "designs": "designs", "require": "conditions",
}


def _conditions(given: tuple[Any, ...]) -> Any:
    """The --require options given, as the board's conditions (CLEAR when one is `none`); None
    when none is given."""
    if not given:
        return None
    if any(value is CLEAR for value in given):
        if len(given) > 1:
            raise click.BadParameter("`none` clears the conditions: give it alone",
                                     param_hint="'--require'")
        return CLEAR
    return dict(given)


def board_spec(options: Mapping[str, Any]) -> BoardSpec:
    """A new board from the options of ``drboard board create`` (unset ones take the defaults)."""
    from drboard_functions.models.requests import BoardSpec

    options = {**options, "require": _conditions(tuple(options.get("require") or ()))}
    fields = {_FIELD_OF_OPTION[name]: value for name, value in options.items() if value is not None}
    opens_at, closes_at = fields.get("opens_at"), fields.get("closes_at")
    if opens_at and closes_at and closes_at <= opens_at:
        raise click.BadParameter("must be after --opens-at", param_hint="'--closes-at'")
    return validated(BoardSpec, fields)


def board_changes(options: Mapping[str, Any]) -> BoardChanges:
    """An update with only the options given; ``none`` clears (a cooldown cleared is no cooldown)."""
    from drboard_functions.models.requests import BoardChanges

    fields: dict[str, Any] = {}
    options = {**options, "require": _conditions(tuple(options.get("require") or ()))}
    for name, value in options.items():
        if value is None:
            continue
        field = _FIELD_OF_OPTION[name]
        if value is CLEAR:
            value = 0 if field == "cooldown_s" else None
        fields[field] = value
    if not fields:
        raise click.UsageError("give at least one option to change; see `drboard board update --help`")
    return validated(BoardChanges, fields)


def validated(model: type[M], fields: dict[str, Any],
              options: Mapping[str, str] = OPTION_OF_FIELD) -> M:
    """The model the options make, or one message naming the option (``options``: the option
    each field comes from) that is wrong."""
    from pydantic import ValidationError

    try:
        return model.model_validate(fields)
    except ValidationError as error:
        problem = error.errors()[0]
        field = str(problem["loc"][0]) if problem["loc"] else ""
        message = problem["msg"].removeprefix("Value error, ")
        if problem["type"] == "string_pattern_mismatch":
            what = "a board id" if field == "board_id" else "an id"
            message = f"{problem['input']!r} is not {what}: {BOARD_ID_RULE}"
        raise click.BadParameter(message, param_hint=f"'{options.get(field, field)}'") from None
