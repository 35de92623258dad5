"""Run parameter files (training_params*.yaml, evaluation_params.yaml, eval_params_*.yaml).

Values arrive as quoted strings, typed scalars or one-item lists depending on who wrote the file,
so every accessor normalises them.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Any, Literal

from .errors import AssemblyError
from .reading import parse_yaml

ParamsKind = Literal["training", "evaluation"]

_EVALUATION_NAME = re.compile(r"^(evaluation_params|eval_params)", re.IGNORECASE)
_TRUE = {"true", "yes", "1", "on"}
_FALSE = {"false", "no", "0", "off"}


@dataclass(frozen=True)
class RunParams:
    name: str
    kind: ParamsKind
    values: dict[str, Any]

    def text(self, key: str) -> str | None:
        value = self.values.get(key)
        if isinstance(value, list):
            # DeepRacer-for-Cloud lists one value per car; the racer's own car comes first.
            if not value:
                return None
            value = value[0]
        if value is None:
            return None
        if isinstance(value, dict | list):
            raise AssemblyError(self.name, key, "expected a single value")
        if isinstance(value, bool):
            return "true" if value else "false"
        text = str(value).strip()
        return text or None

    def flag(self, key: str) -> bool | None:
        text = self.text(key)
        if text is None:
            return None
        if text.lower() in _TRUE:
            return True
        if text.lower() in _FALSE:
            return False
        raise AssemblyError(self.name, key, f"expected true or false, found {text!r}")

    def number(self, key: str, low: float, high: float) -> float | None:
        """The value as a number within low..high, None where the parameters leave it out."""
        text = self.text(key)
        if text is None or text.lower() in ("none", "null"):
            return None
        try:
            value = float(text) if len(text) <= 32 else math.nan
        except ValueError:
            value = math.nan
        if not low <= value <= high:  # also NaN
            raise AssemblyError(self.name, key, f"expected a number from {low:g} to {high:g}, "
                                f"found {text[:40]!r}")
        return value

    def whole(self, key: str, low: int, high: int) -> int | None:
        """The value as a whole number within low..high, None where it is left out."""
        value = self.number(key, low, high)
        if value is None:
            return None
        if not value.is_integer():
            raise AssemblyError(self.name, key, f"expected a whole number, found {value:g}")
        return int(value)

    def items(self, key: str) -> int | None:
        """How many items a list value holds, None where the key is left out."""
        value = self.values.get(key)
        if value is None:
            return None
        return len(value) if isinstance(value, list) else None

    @property
    def metrics_file(self) -> str | None:
        """The base name of the metrics file this run wrote (``METRICS_S3_OBJECT_KEY``)."""
        key = self.text("METRICS_S3_OBJECT_KEY")
        return PurePosixPath(key).name if key else None


def load_params(data: bytes, name: str) -> RunParams:
    return params_from_values(parse_yaml(data, name), name)


def params_from_values(values: dict[Any, Any], name: str) -> RunParams:
    """Run parameters from a mapping: a params YAML's, or the one a job printed in its log."""
    for key in values:
        if not isinstance(key, str):
            raise AssemblyError(name, str(key), "keys must be names")
    return RunParams(name=name, kind=_kind(values, name), values=values)


def _kind(values: dict[str, Any], name: str) -> ParamsKind:
    # The job type decides: DeepRacer on AWS writes every job's parameters, evaluations and
    # submissions included, as training_params.yaml.
    job = str(_first(values.get("JOB_TYPE")) or "").strip().upper()
    if job in ("EVALUATION", "SUBMISSION"):
        return "evaluation"
    if job == "TRAINING":
        return "training"
    if _EVALUATION_NAME.match(PurePosixPath(name).name):
        return "evaluation"
    if "NUMBER_OF_TRIALS" in values and "NUMBER_OF_EPISODES" not in values:
        return "evaluation"
    return "training"


def _first(value: Any) -> Any:
    return value[0] if isinstance(value, list) and value else value
