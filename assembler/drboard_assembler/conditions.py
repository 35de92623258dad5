"""Step 6, the conditions: the rules each evaluation ran under, from the parameters that
describe it (an evaluation params file, or the parameters its log printed).

Only what the parameters state is kept: the simulator's defaults for a missing key changed
between versions, so a condition no file states is unknown rather than guessed. The keys are
the simulator's (deepracer-simapp's evaluation worker): ``OFF_TRACK_PENALTY`` and
``COLLISION_PENALTY`` (seconds the car is held after an off-track or a collision, counted in
the lap's time), ``NUMBER_OF_RESETS``, ``NUMBER_OF_TRIALS``, ``IS_CONTINUOUS``,
``NUMBER_OF_OBSTACLES`` (or the ``OBJECT_POSITIONS`` that replace it) and ``NUMBER_OF_BOT_CARS``.
"""

from __future__ import annotations

from .params import RunParams
from .reading import validate
from .record import Conditions


def conditions_of(params: RunParams | None) -> Conditions | None:
    """The conditions the evaluation parameters state, or None where they state none."""
    if params is None or params.kind != "evaluation":
        return None
    stated = {name: value for name, value in _read(params).items() if value is not None}
    if not stated:
        return None
    return validate(Conditions, {**stated, "source": params.name}, params.name)


def _read(params: RunParams) -> dict[str, object]:
    positions = params.items("OBJECT_POSITIONS")
    return {
        "off_track_penalty_s": params.number("OFF_TRACK_PENALTY", 0, 3600),
        "collision_penalty_s": params.number("COLLISION_PENALTY", 0, 3600),
        "max_resets": params.whole("NUMBER_OF_RESETS", 0, 1_000_000),
        "trials": params.whole("NUMBER_OF_TRIALS", 1, 100_000),
        "continuous": params.flag("IS_CONTINUOUS"),
        "obstacles": positions or params.whole("NUMBER_OF_OBSTACLES", 0, 1000),
        "bots": params.whole("NUMBER_OF_BOT_CARS", 0, 1000),
    }
