"""drboard's assembler: a DeepRacer run folder -> one validated Record. No AWS, no network.

The Record schema and the track catalog import lightly; the file readers (YAML, archives) load
on first use, so the Lambda functions, which only validate records, never import them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .catalog import TrackCatalog, UnknownTrackError, default_catalog
from .errors import AssemblyError
from .record import Record

if TYPE_CHECKING:
    from .assembly import Overrides, assemble, planned_trials
    from .layout import evaluation_files

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


def __getattr__(name: str) -> Any:
    if name in ("Overrides", "assemble", "planned_trials"):
        from . import assembly

        return getattr(assembly, name)
    if name == "evaluation_files":
        from . import layout

        return layout.evaluation_files
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
