"""The evaluation conditions a board requires, against the ones a run's evaluation ran under.

It imports no model: `drboard pull` words the conditions of the standings kept beside the
embedded board, which are JSON read back (:func:`stated_values`), without loading the models.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from drboard_assembler.record import Conditions, EvaluationRun

    from .models.domain import BoardConditions

#: How each condition reads, in the order they are listed.
LABELS = {
    "off_track_penalty_s": "off-track penalty",
    "collision_penalty_s": "collision penalty",
    "max_resets": "resets",
    "trials": "trials",
    "continuous": "continuous",
    "obstacles": "obstacles",
    "bots": "bot cars",
}
#: Penalties are seconds the simulator was given as text: equal within this.
_SAME_S = 1e-6


def value_text(name: str, value: Any) -> str:
    """``5 s``, ``3``, ``yes``; ``unknown`` where the evaluation's parameters do not say."""
    if value is None:
        return "unknown"
    if name.endswith("_s"):
        return f"{value:g} s"
    if name == "continuous":
        return "yes" if value else "no"
    return str(value)


def condition_text(name: str, value: Any) -> str:
    """``off-track penalty 5 s``, ``trials 3``, ``continuous no``."""
    return f"{LABELS[name]} {value_text(name, value)}"


def unmet(required: BoardConditions | None, stated: Conditions | None) -> list[str]:
    """Each required condition the run's evaluation was not run under, in words:
    ``off-track penalty 2 s (the board requires 5 s)``; empty when it meets them all."""
    if required is None:
        return []
    have = stated.stated() if stated is not None else {}
    return [f"{_as_stated(name, have.get(name))} (the board requires {value_text(name, wanted)})"
            for name, wanted in required.required().items() if not _same(have.get(name), wanted)]


def _as_stated(name: str, value: Any) -> str:
    if value is None:
        return f"{LABELS[name]} not stated by its evaluation parameters"
    return condition_text(name, value)


def meets(required: BoardConditions | None, run: EvaluationRun) -> bool:
    return not unmet(required, run.conditions)


def stated_values(conditions: Conditions | BoardConditions | Mapping[str, Any]) -> dict[str, Any]:
    """The conditions stated, by name: of a run's or a board's conditions, or of their JSON read
    back as a mapping (where every condition is written, those not stated as null)."""
    if isinstance(conditions, Mapping):
        return {name: value for name, value in conditions.items()
                if name in LABELS and value is not None}
    return {name: value for name, value in conditions.model_dump(exclude_none=True).items()
            if name in LABELS}


def summary(conditions: Conditions | BoardConditions | Mapping[str, Any] | None) -> str:
    """The conditions stated, on one line (``off-track penalty 5 s · trials 3``); "" for none."""
    if conditions is None:
        return ""
    values = stated_values(conditions)
    return " · ".join(condition_text(name, values[name]) for name in LABELS if name in values)


_SHORT = {"off_track_penalty_s": "off-track {} s", "collision_penalty_s": "collision {} s",
          "max_resets": "{} resets", "trials": "{} trials", "obstacles": "{} obstacles",
          "bots": "{} bots"}


def short(conditions: Conditions | Mapping[str, Any] | None) -> str:
    """The conditions stated, for a table's cell: ``off-track 5 s, 3 trials, continuous``;
    ``unknown`` when the evaluation's parameters state none."""
    if conditions is None:
        return "unknown"
    values = stated_values(conditions)
    parts = []
    for name in LABELS:
        if name not in values:
            continue
        value = values[name]
        if name == "continuous":
            parts.append("continuous" if value else "not continuous")
        else:
            parts.append(_SHORT[name].format(f"{value:g}" if isinstance(value, float) else value))
    return ", ".join(parts)


def rows(conditions: Conditions | None) -> list[tuple[str, str]]:
    """Each condition, unknown where the evaluation's parameters do not state it."""
    values = conditions.stated() if conditions is not None else {}
    return [(label, value_text(name, values.get(name))) for name, label in LABELS.items()]


#: What a lap's time holds, wherever conditions are shown.
PENALTIES_NOTE = ("Lap times include the penalties: the simulator holds the car for the off-track "
                  "or collision penalty's seconds and times a lap from its start to its end, as the "
                  "league timed it.")


def _same(value: Any, wanted: Any) -> bool:
    if value is None:
        return False
    if isinstance(wanted, float) or isinstance(value, float):
        return abs(float(value) - float(wanted)) <= _SAME_S
    return bool(value == wanted)
