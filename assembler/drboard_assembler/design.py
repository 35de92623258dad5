"""Step 5, the design: each fact of the evaluated model's design from the file that describes
that model, and the file named beside it.

- The action space, algorithm, sensors, network and metadata version: the evaluation log prints
  the evaluated model's (``Action space from file: ...`` and the ``Sensor list ...`` line); a
  ``model_metadata.json`` whose action space disagrees with it describes another model and is not
  used. Without such a log, the model's ``model_metadata.json``; without that, what the model's
  training log printed.
- The hyperparameters: the model's ``hyperparameters.json``, else the block its training log
  printed. Never an evaluation log's: an evaluation job prints its worker's defaults.
- Whatever no file states is unknown (None).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, ValidationError

from .errors import AssemblyError
from .logs import JobLog
from .reading import parse_json, validate
from .record import Action, ActionSpace, Design, DesignSources, Hyperparameters, Range

_LOSS_TYPES = {"huber": "huber", "mean squared error": "mean_squared_error",
               "mean_squared_error": "mean_squared_error"}
#: Two action spaces are the same when every figure agrees this closely (a log prints
#: -10.000000000000004 where the metadata says -10).
_SAME = 1e-6


class _ContinuousSpace(BaseModel):
    model_config = ConfigDict(extra="ignore")
    speed: Range
    steering_angle: Range


def _action_space_kind(value: Any) -> str:
    # Choose the branch by shape, so an error names the field at fault (not the other branch).
    return "discrete" if isinstance(value, list) else "continuous"


SpaceField = Annotated[
    Annotated[list[Action], Field(min_length=1), Tag("discrete")]
    | Annotated[_ContinuousSpace, Tag("continuous")],
    Discriminator(_action_space_kind),
]


class _Metadata(BaseModel):
    model_config = ConfigDict(extra="ignore")
    action_space: SpaceField
    action_space_type: str | None = None
    training_algorithm: str = "clipped_ppo"
    sensor: list[str] = Field(default_factory=list)
    neural_network: str | None = None
    version: str | int | float | None = None


class _Printed(BaseModel):
    """What a job's log printed of its model: each part only where the log printed it."""

    model_config = ConfigDict(extra="ignore")
    action_space: SpaceField | None = None
    action_space_type: str | None = None
    training_algorithm: str | None = None
    sensor: list[str] | None = None
    neural_network: str | None = None
    version: str | None = None


@dataclass(frozen=True)
class Facts:
    """One file's description of a model, and the file."""

    source: str
    action_space: ActionSpace | None
    algorithm: str | None
    sensors: list[str] | None
    neural_network: str | None
    metadata_version: str | None


@dataclass(frozen=True)
class NamedFile:
    name: str
    data: bytes


def metadata_facts(metadata: NamedFile) -> Facts:
    """A model_metadata.json's facts; a file that is not one is refused, naming the field."""
    meta = validate(_Metadata, parse_json(metadata.data, metadata.name), metadata.name)
    return _checked(Facts(
        source=metadata.name,
        action_space=_action_space(meta.action_space, meta.action_space_type, metadata.name),
        algorithm=_algorithm(meta.training_algorithm, metadata.name),
        sensors=meta.sensor,
        neural_network=meta.neural_network,
        metadata_version=_version(meta.version),
    ))


def printed_facts(log: JobLog) -> Facts | None:
    """What a log printed of its model, or None where it printed nothing of it (a part it
    printed garbled counts as not printed)."""
    try:
        printed = _Printed.model_validate({
            "action_space": log.action_space, "action_space_type": log.action_space_type,
            "training_algorithm": log.algorithm, "sensor": log.sensors,
            "neural_network": log.network, "version": _version(log.simapp_version, printed=True),
        })
        space = (None if printed.action_space is None else
                 _action_space(printed.action_space, printed.action_space_type, log.name))
        algorithm = _algorithm(printed.training_algorithm, log.name) if printed.training_algorithm else None
        if space is None and algorithm is None and printed.sensor is None:
            return None
        return _checked(Facts(log.name, space, algorithm, printed.sensor, printed.neural_network,
                              printed.version))
    except (ValidationError, AssemblyError):
        return None


def _checked(facts: Facts) -> Facts:
    """The facts, once the record's bounds hold for each (else one error naming the file)."""
    validate(Design, {"algorithm": facts.algorithm, "action_space": facts.action_space,
                      "sensors": facts.sensors, "neural_network": facts.neural_network,
                      "metadata_version": facts.metadata_version}, facts.source)
    return facts


def same_action_space(one: ActionSpace | None, other: ActionSpace | None) -> bool:
    if one is None or other is None or one.type != other.type:
        return False
    if one.actions is not None and other.actions is not None:
        return len(one.actions) == len(other.actions) and all(
            abs(a.speed - b.speed) <= _SAME and abs(a.steering_angle - b.steering_angle) <= _SAME
            for a, b in zip(one.actions, other.actions, strict=True))
    return _ranges(one) == _ranges(other)


def _ranges(space: ActionSpace) -> tuple[float, ...]:
    assert space.speed is not None and space.steering_angle is not None
    return tuple(round(value, 6) for value in (space.speed.low, space.speed.high,
                                               space.steering_angle.low, space.steering_angle.high))


#: The facts a model's metadata (or what a job printed of it) states.
_DESCRIBED = ("algorithm", "action_space", "sensors", "neural_network", "metadata_version")


def build_design(model: Facts | None, evaluated: Facts | None, trained: Facts | None,
                 hyperparameters: NamedFile | None, training_log: JobLog | None) -> Design:
    """The design from the model's metadata, what its evaluation printed, what its training
    printed, and its hyperparameters (a file, or a training log's block)."""
    facts = _described_by(model, evaluated, trained)
    values = {name: getattr(facts, name) if facts else None for name in _DESCRIBED}
    sources = {name: facts.source if facts and value is not None else None for name, value in values.items()}
    hyper, hyper_source = _hyperparameters_of(hyperparameters, training_log)
    return Design.model_validate({**values, "hyperparameters": hyper,
                                  "sources": DesignSources(**sources, hyperparameters=hyper_source)})


def load_design(metadata: bytes, metadata_name: str, hyperparameters: bytes | None,
                hyperparameters_name: str) -> Design:
    """The design a model_metadata.json and a hyperparameters.json describe, on their own."""
    hyper = NamedFile(hyperparameters_name, hyperparameters) if hyperparameters is not None else None
    return build_design(metadata_facts(NamedFile(metadata_name, metadata)), None, None, hyper, None)


def _described_by(model: Facts | None, evaluated: Facts | None, trained: Facts | None) -> Facts | None:
    """The metadata when nothing contradicts it, else what the evaluation printed, else what
    the training printed."""
    if evaluated is not None and evaluated.action_space is not None:
        if model is not None and same_action_space(model.action_space, evaluated.action_space):
            return model
        return evaluated
    return model or evaluated or trained


def _hyperparameters_of(file: NamedFile | None,
                        training_log: JobLog | None) -> tuple[Hyperparameters | None, str | None]:
    if file is not None:
        return _hyperparameters(parse_json(file.data, file.name), file.name), file.name
    if training_log is not None and training_log.hyperparameters is not None:
        try:
            return _hyperparameters(training_log.hyperparameters, training_log.name), training_log.name
        except AssemblyError:
            return None, None  # a garbled block: the log states nothing usable
    return None, None


def _algorithm(text: str, name: str) -> str:
    algorithm = text.strip().lower()
    if algorithm not in ("clipped_ppo", "sac"):
        raise AssemblyError(name, "training_algorithm", f"expected clipped_ppo or sac, found {text!r}")
    return algorithm


def _action_space(space: Any, declared_type: str | None, name: str) -> ActionSpace:
    declared = (declared_type or "").strip().lower() or None
    if isinstance(space, list):
        if declared not in (None, "discrete"):
            raise AssemblyError(name, "action_space_type",
                                f"says {declared!r} but action_space is a list of actions")
        fields: dict[str, Any] = {
            "type": "discrete",
            "actions": space,
            "max_speed": max(a.speed for a in space),
            "max_steering": max(abs(a.steering_angle) for a in space),
        }
    else:
        if declared not in (None, "continuous"):
            raise AssemblyError(name, "action_space_type",
                                f"says {declared!r} but action_space holds ranges")
        fields = {
            "type": "continuous",
            "speed": space.speed,
            "steering_angle": space.steering_angle,
            "max_speed": space.speed.high,
            "max_steering": max(abs(space.steering_angle.low), abs(space.steering_angle.high)),
        }
    return validate(ActionSpace, fields, f"{name}: action_space")


def _version(value: str | int | float | None, *, printed: bool = False) -> str | None:
    """The metadata version as text; a log prints it as a float (``4.0`` for ``"4"``)."""
    if value is None:
        return None
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    text = str(value).strip()
    if printed and text.endswith(".0") and text[:-2].isdigit():
        text = text[:-2]
    return text or None


def _hyperparameters(raw: Any, name: str) -> Hyperparameters:
    if not isinstance(raw, dict):
        raise AssemblyError(name, "(top level)", "must be a JSON object")
    known = set(Hyperparameters.model_fields) - {"other"}
    fields: dict[str, Any] = {}
    other: dict[str, Any] = {}
    for key, value in raw.items():
        if key == "loss_type" and isinstance(value, str):
            normalised = _LOSS_TYPES.get(value.strip().lower())
            if normalised is None:
                raise AssemblyError(name, key, f"unknown loss type {value!r}")
            value = normalised
        if key in known:
            fields[key] = value
        elif isinstance(value, bool | int | float | str):
            other[key] = value
        else:
            raise AssemblyError(name, key, "expected a number, a string or true/false")
    fields["other"] = other
    return validate(Hyperparameters, fields, name)
