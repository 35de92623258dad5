"""Which board a track's name means: a track's default board ids, worked out from the track
catalog alone (no model is imported, so that `drboard pull --track` resolves its board before
anything heavier loads)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from drboard_assembler.catalog import UnknownTrackError, default_catalog

if TYPE_CHECKING:
    from drboard_assembler.record import RaceType

#: Each race type's suffix to its track's default board id (keyed by the race types' values,
#: which the ``RaceType`` members equal).
RACE_SUFFIX: dict[str, str] = {
    "TIME_TRIAL": "",
    "OBJECT_AVOIDANCE": "_oa",
    "HEAD_TO_BOT": "_h2b",
    "HEAD_TO_MODEL": "_h2m",
    "HEAD_TO_HEAD_RACING": "_h2h",
    "F1": "_f1",
}

#: A custom track's default boards are ``custom.<track>...``: a push for a track of one's own
#: can take neither an official track's board id nor a named board's (which may not start so).
CUSTOM_PREFIX = "custom."


def default_board_id(track: str, direction: str | None, race_type: RaceType | str) -> str:
    """A track's default board: counter-clockwise and unspecified runs share the track's board;
    clockwise runs, and race types other than time trial, rank on boards of their own."""
    prefix = "" if default_catalog().is_official(track) else CUSTOM_PREFIX
    return prefix + track + ("_cw" if direction == "cw" else "") + RACE_SUFFIX[race_type]


def board_for_track(name: str, race_type: RaceType | str = "TIME_TRIAL", clockwise: bool = False) -> str:
    """The default board of a track given by any of its names (``reInvent2019``, ``Smile
    Speedway``, ``reInvent2019_track_cw``), or by the id of one of its default boards as a push
    prints it (``Belille_oa``). An unknown name is taken as a custom track's id."""
    try:
        resolved = default_catalog().resolve(name)
    except UnknownTrackError as error:
        if race_type == "TIME_TRIAL" and (board := _named_by_board_id(name.strip())):
            return board
        if error.ambiguous or error.candidates:
            from .errors import InvalidQuery

            raise InvalidQuery(str(error)) from None
        return default_board_id(name.strip(), "cw" if clockwise else None, race_type)
    direction = "cw" if clockwise else resolved.direction
    return default_board_id(resolved.track_id, direction, race_type)


def _named_by_board_id(name: str) -> str | None:
    """The default board a name ending in a race type's suffix (``_oa``, ``_h2b``, …) names, if
    the rest of it is a track's name."""
    for race_type, suffix in RACE_SUFFIX.items():
        if suffix and name.endswith(suffix) and len(name) > len(suffix):
            try:
                resolved = default_catalog().resolve(name[: -len(suffix)])
            except UnknownTrackError:
                return None
            return default_board_id(resolved.track_id, resolved.direction, race_type)
    return None


def is_default_board_id(board_id: str) -> bool:
    """Whether the id is the default board of a catalog track (for any direction and race)."""
    catalog = default_catalog()
    for race_suffix in RACE_SUFFIX.values():
        for direction in ("_cw", ""):
            suffix = direction + race_suffix
            base = board_id[: len(board_id) - len(suffix)] if suffix else board_id
            if board_id.endswith(suffix) and base and catalog.get(base) is not None:
                return True
    return False


def made_by_a_push(board_id: str) -> bool:
    """Whether a run's push makes the board when it is missing: a catalog track's default board,
    or a custom track's. Any other board is an organiser's to create."""
    return is_default_board_id(board_id) or board_id.startswith(CUSTOM_PREFIX)
