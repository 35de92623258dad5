"""Model metadata and hyperparameters -> the record's Design."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag

from .errors import AssemblyError
from .reading import parse_json, validate
from .record import Action, ActionSpace, Design, Hyperparameters, Range

_LOSS_TYPES = {"huber": "huber", "mean squared error": "mean_squared_error",
               "mean_squared_error": "mean_squared_error"}


class _ContinuousSpace(BaseModel):
    model_config = ConfigDict(extra="ignore")
    speed: Range
    steering_angle: Range


def _action_space_kind(value: Any) -> str:
    # Choose the branch by shape, so an error names the field at fault (not the other branch).
    return "discrete" if isinstance(value, list) else "continuous"


class _Metadata(BaseModel):
    model_config = ConfigDict(extra="ignore")
    action_space: Annotated[
        Annotated[list[Action], Field(min_length=1), Tag("discrete")]
        | Annotated[_ContinuousSpace, Tag("continuous")],
        Discriminator(_action_space_kind),
    ]
    action_space_type: str | None = None
    training_algorithm: str = "clipped_ppo"
    sensor: list[str] = Field(default_factory=list)
    neural_network: str | None = None
    version: str | int | float | None = None


def load_design(metadata: bytes, metadata_name: str,
                hyperparameters: bytes | None, hyperparameters_name: str) -> Design:
    meta = validate(_Metadata, parse_json(metadata, metadata_name), metadata_name)
    algorithm = meta.training_algorithm.strip().lower()
    if algorithm not in ("clipped_ppo", "sac"):
        raise AssemblyError(metadata_name, "training_algorithm",
                            f"expected clipped_ppo or sac, found {meta.training_algorithm!r}")
    params = (_hyperparameters(parse_json(hyperparameters, hyperparameters_name),
                               hyperparameters_name)
              if hyperparameters is not None else Hyperparameters())
    fields = {
        "algorithm": algorithm,
        "action_space": _action_space(meta, metadata_name),
        "sensors": meta.sensor,
        "neural_network": meta.neural_network,
        "metadata_version": _version(meta.version),
        "hyperparameters": params,
    }
    return validate(Design, fields, metadata_name)


def _action_space(meta: _Metadata, name: str) -> ActionSpace:
    declared = (meta.action_space_type or "").strip().lower() or None
    if isinstance(meta.action_space, list):
        if declared not in (None, "discrete"):
            raise AssemblyError(name, "action_space_type",
                                f"says {declared!r} but action_space is a list of actions")
        actions = meta.action_space
        fields: dict[str, Any] = {
            "type": "discrete",
            "actions": actions,
            "max_speed": max(a.speed for a in actions),
            "max_steering": max(abs(a.steering_angle) for a in actions),
        }
    else:
        if declared not in (None, "continuous"):
            raise AssemblyError(name, "action_space_type",
                                f"says {declared!r} but action_space holds ranges")
        space = meta.action_space
        fields = {
            "type": "continuous",
            "speed": space.speed,
            "steering_angle": space.steering_angle,
            "max_speed": space.speed.high,
            "max_steering": max(abs(space.steering_angle.low), abs(space.steering_angle.high)),
        }
    return validate(ActionSpace, fields, f"{name}: action_space")


def _version(value: str | int | float | None) -> str | None:
    if value is None:
        return None
    if isinstance(value, float) and value.is_integer():
        return str(int(value))
    return str(value).strip() or None


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
