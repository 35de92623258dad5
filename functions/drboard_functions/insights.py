"""How the fast models were built: a design's facts, what two designs differ on, and what the top
models share against the field. Pure functions of records; the service fetches them."""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

from drboard_assembler.record import Hyperparameters, Record

from .display import DASH, UNKNOWN, algorithm_name
from .models.racer_views import DesignFacts, SharedFact

#: The facts insights summarise, with how people read them (in this order).
LABELS = {
    "algorithm": "algorithm",
    "action_space": "action space",
    "actions": "actions",
    "max_speed": "top speed (m/s)",
    "min_speed": "lowest speed (m/s)",
    "max_steering": "steering range (±°)",
    "sensors": "sensors",
    "neural_network": "network",
    "discount_factor": "discount factor",
    "learning_rate": "learning rate",
    "batch_size": "batch size",
    "entropy": "entropy",
    "epochs": "epochs",
    "episodes_between_training": "episodes per training",
    "loss_type": "loss",
    "training_time_s": "training time (s)",
    "training_episodes": "training episodes",
}
CHOICES = {"algorithm", "action_space", "sensors", "neural_network", "loss_type"}


def design_facts(record: Record) -> DesignFacts:
    """The design's facts; None for each the run's files do not state (insights leave those out,
    and a comparison shows them as unknown)."""
    design, space = record.design, record.design.action_space
    hyper = design.hyperparameters or Hyperparameters()
    speeds = [] if space is None else ([a.speed for a in space.actions] if space.actions
                                       else [space.speed.low] if space.speed else [])
    return DesignFacts(
        algorithm=design.algorithm,
        action_space=space.type if space else None,
        actions=len(space.actions) if space and space.actions else None,
        max_speed=space.max_speed if space else None,
        min_speed=min(speeds) if speeds else None,
        max_steering=space.max_steering if space else None,
        sensors=sorted(design.sensors) if design.sensors is not None else None,
        neural_network=design.neural_network,
        discount_factor=hyper.discount_factor,
        learning_rate=hyper.lr,
        batch_size=hyper.batch_size,
        entropy=hyper.beta_entropy,
        epochs=hyper.num_epochs,
        episodes_between_training=hyper.num_episodes_between_training,
        loss_type=hyper.loss_type,
        training_time_s=record.training.training_time_s if record.training else None,
        training_episodes=record.training.episodes if record.training else None,
        unknown=unknown_facts(record),
    )


_SPACE_FACTS = ("action_space", "actions", "max_speed", "min_speed", "max_steering")
_HYPER_FACTS = ("discount_factor", "learning_rate", "batch_size", "entropy", "epochs",
                "episodes_between_training", "loss_type")


def unknown_facts(record: Record) -> list[str]:
    """The facts the run's files do not state, in LABELS order."""
    design = record.design
    unknown: set[str] = set()
    if design.action_space is None:
        unknown.update(_SPACE_FACTS)
    if design.hyperparameters is None:
        unknown.update(_HYPER_FACTS)
    if record.training is None:
        unknown.update(("training_time_s", "training_episodes"))
    for name in ("algorithm", "sensors", "neural_network"):
        if getattr(design, name) is None:
            unknown.add(name)
    return [name for name in LABELS if name in unknown]


def differences(facts: Sequence[DesignFacts]) -> list[str]:
    """The facts on which the designs do not all agree, in LABELS order."""
    dumped = [f.model_dump() for f in facts]
    return [name for name in LABELS if len({_key(d[name]) for d in dumped}) > 1]


#: What an algorithm fixes by itself, whatever its racer chose: DeepRacer's SAC trains only a
#: continuous action space (so no count of actions), and has neither PPO's entropy coefficient
#: nor its epochs among its hyperparameters.
FIXED_BY_ALGORITHM: dict[str, dict[str, Any]] = {
    "sac": {"action_space": "continuous", "actions": None, "entropy": None, "epochs": None},
}


def algorithm_differences(facts: Sequence[DesignFacts], differing: Sequence[str]) -> list[str]:
    """Of the facts the designs differ on, those that follow from their algorithms alone: the
    algorithms differ, and a design holds the value its algorithm fixes."""
    if len({f.algorithm for f in facts}) < 2:
        return []
    return [name for name in differing
            if any(name in (fixed := FIXED_BY_ALGORITHM.get(f.algorithm or "", {}))
                   and getattr(f, name) == fixed[name] for f in facts)]


def shared_facts(top: Sequence[DesignFacts], field: Sequence[DesignFacts]) -> list[SharedFact]:
    """Each fact of the top designs against the field's: the most common choice and its share,
    or the median number. Facts no design states are left out."""
    from statistics import median  # only the insights use it: a cold start does not load it

    shared = []
    for name, label in LABELS.items():
        top_values = [v for f in top if (v := getattr(f, name)) is not None]
        field_values = [v for f in field if (v := getattr(f, name)) is not None]
        if not top_values or not field_values:
            continue
        if name in CHOICES:
            choice, count = Counter(_key(v) for v in top_values).most_common(1)[0]
            in_field = sum(1 for v in field_values if _key(v) == choice)
            shared.append(SharedFact(fact=name, label=label, top=fact_text(name, choice),
                                     field=fact_text(name, choice),
                                     top_share=round(count / len(top_values), 3),
                                     field_share=round(in_field / len(field_values), 3)))
        else:
            shared.append(SharedFact(fact=name, label=label,
                                     top=fact_text(name, median(top_values)),
                                     field=fact_text(name, median(field_values))))
    return shared


def fact_text(name: str, value: Any, unknown: bool = False) -> str:
    """A fact's value as people read it; one the run's files do not state, as unknown (a fact
    that does not apply, such as a continuous action space's count of actions, as a dash)."""
    if value is None:
        return UNKNOWN if unknown else DASH
    if name == "algorithm":
        return algorithm_name(str(value))
    if isinstance(value, tuple | list):
        return ", ".join(value) or "none"
    if isinstance(value, float):
        return f"{value:g}" if name != "training_time_s" else f"{value:.0f}"
    return str(value)


def _key(value: Any) -> Any:
    return tuple(value) if isinstance(value, list) else value
