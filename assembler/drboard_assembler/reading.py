"""Bounded, field-naming readers for the JSON and YAML files racers have."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from .errors import AssemblyError, field_path

ModelT = TypeVar("ModelT", bound=BaseModel)


def read_bounded(path: Path, name: str, max_bytes: int) -> bytes:
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise AssemblyError(name, "", f"is {_size(size)}, over the {_size(max_bytes)} limit")
        with path.open("rb") as handle:
            data = handle.read(max_bytes + 1)
    except OSError as error:
        raise AssemblyError(name, "", f"cannot be read: {error.strerror or error}") from None
    if len(data) > max_bytes:
        raise AssemblyError(name, "", f"is over the {_size(max_bytes)} limit")
    return data


def _size(count: int) -> str:
    if count < 1024:
        return f"{count} bytes"
    if count < 1024 * 1024:
        return f"{count / 1024:.2f} KiB"
    return f"{count / (1024 * 1024):.2f} MiB"


def parse_json(data: bytes, name: str) -> Any:
    try:
        return json.loads(data)
    except json.JSONDecodeError as error:
        where = f"line {error.lineno} column {error.colno}"
        raise AssemblyError(name, where, f"not valid JSON ({error.msg})") from None
    except (UnicodeDecodeError, RecursionError) as error:
        raise AssemblyError(name, "", f"not valid JSON ({type(error).__name__})") from None


def validate_json(model: type[ModelT], data: bytes, name: str) -> ModelT:
    """Parse and validate in one pass (pydantic's own parser: fast on large metrics files)."""
    try:
        return model.model_validate_json(data)
    except ValidationError as error:
        raise from_validation_error(error, name) from None


def validate(model: type[ModelT], value: Any, name: str) -> ModelT:
    try:
        return model.model_validate(value)
    except ValidationError as error:
        raise from_validation_error(error, name) from None


def from_validation_error(error: ValidationError, name: str) -> AssemblyError:
    first = error.errors(include_url=False)[0]
    if first["type"] in ("json_invalid", "json_type"):
        return AssemblyError(name, "", f"not valid JSON ({first['msg']})")
    return AssemblyError(name, field_path(first["loc"]) or "(top level)", first["msg"])


def parse_yaml(data: bytes, name: str) -> dict[str, Any]:
    try:
        value = yaml.safe_load(data)
    except yaml.constructor.ConstructorError as error:
        where = _yaml_where(error)
        raise AssemblyError(name, where, f"YAML tag not allowed ({error.problem})") from None
    except yaml.YAMLError as error:
        raise AssemblyError(name, _yaml_where(error), "not valid YAML") from None
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise AssemblyError(name, "(top level)", "must be a mapping of KEY: value")
    return value


def _yaml_where(error: yaml.YAMLError) -> str:
    mark = getattr(error, "problem_mark", None)
    return f"line {mark.line + 1}" if mark is not None else ""
