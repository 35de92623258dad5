"""drboard's assembler: a DeepRacer run folder -> one validated Record. No AWS, no network.

Importing the package loads none of its modules: each name below loads its module on first use
(``from drboard_assembler import limits`` reads a few constants, not the Record schema), so a
Lambda function or a CLI command pays only for what it uses, and the file readers (YAML,
archives) load only where runs are assembled.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .assembly import Overrides, assemble, planned_trials
    from .catalog import TrackCatalog, UnknownTrackError, default_catalog
    from .errors import AssemblyError
    from .layout import evaluation_files
    from .record import Record

__version__ = "0.1.0"

__all__ = [
    "AssemblyError",
    "Overrides",
    "Record",
    "TrackCatalog",
    "UnknownTrackError",
    "__version__",
    "assemble",
    "default_catalog",
    "evaluation_files",
    "planned_trials",
]


#: Where each exported name lives.
_HOMES = {"AssemblyError": "errors", "Overrides": "assembly", "Record": "record",
          "TrackCatalog": "catalog", "UnknownTrackError": "catalog", "assemble": "assembly",
          "default_catalog": "catalog", "evaluation_files": "layout", "planned_trials": "assembly"}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{home}"), name)
