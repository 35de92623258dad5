"""Bounded, field-naming readers for the JSON and YAML files racers have."""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ValidationError

from .errors import AssemblyError, field_path

ModelT = TypeVar("ModelT", bound=BaseModel)


#: YAML nested deeper than this is refused (run parameters are flat: KEY: value).
MAX_YAML_DEPTH = 16


def read_bounded(path: Path, name: str, max_bytes: int) -> bytes:
    """The file's bytes, if it is a regular file of at most ``max_bytes``. Opened without
    blocking, so a FIFO in its place is refused rather than waited on for ever."""
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as error:
        raise AssemblyError(name, "", f"cannot be read: {error.strerror or error}") from None
    with os.fdopen(descriptor, "rb") as handle:
        try:
            status = os.fstat(handle.fileno())
            if not stat.S_ISREG(status.st_mode):
                raise AssemblyError(name, "", "is not a regular file")
            if status.st_size > max_bytes:
                raise AssemblyError(name, "", f"is {_size(status.st_size)}, over the "
                                    f"{_size(max_bytes)} limit")
            # read(n) allocates n bytes up front: ask for the size the file has, not the bound
            data = handle.read(status.st_size + 1)
            if len(data) > status.st_size:  # it grew since: read on, up to the bound
                data += handle.read(max_bytes + 1 - len(data))
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
    except ValueError as error:  # a number of more than 4,300 digits
        raise AssemblyError(name, "", f"not valid JSON ({str(error).split(':')[0]})") from None


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


class _BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader without aliases (a few bytes of them can expand to gigabytes) and
    with a bound on nesting (deep nesting would exhaust the stack). Run parameters need neither."""

    _depth = 0

    def compose_node(self, parent: Any, index: Any) -> Any:
        if self.check_event(yaml.AliasEvent):
            raise yaml.composer.ComposerError(None, None, "aliases (*name) are not allowed",
                                              self._next_mark())
        if self._depth >= MAX_YAML_DEPTH:
            raise yaml.composer.ComposerError(None, None, "nested deeper than "
                                              f"{MAX_YAML_DEPTH} levels is not allowed", self._next_mark())
        self._depth += 1
        try:
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def _next_mark(self) -> Any:
        return self.peek_event().start_mark  # type: ignore[no-untyped-call]


def parse_yaml(data: bytes, name: str) -> dict[str, Any]:
    try:
        value = yaml.load(data, Loader=_BoundedLoader)
    except yaml.composer.ComposerError as error:
        raise AssemblyError(name, _yaml_where(error), str(error.problem)) from None
    except yaml.constructor.ConstructorError as error:
        where = _yaml_where(error)
        raise AssemblyError(name, where, f"YAML tag not allowed ({error.problem})") from None
    except yaml.YAMLError as error:
        raise AssemblyError(name, _yaml_where(error), "not valid YAML") from None
    except (ValueError, RecursionError) as error:  # a 4,300-digit integer; nesting in flow style
        raise AssemblyError(name, "", f"not valid YAML ({str(error).split(':')[0]})") from None
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise AssemblyError(name, "(top level)", "must be a mapping of KEY: value")
    return value


def _yaml_where(error: yaml.YAMLError) -> str:
    mark = getattr(error, "problem_mark", None)
    return f"line {mark.line + 1}" if mark is not None else ""
