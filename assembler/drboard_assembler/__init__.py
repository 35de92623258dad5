"""drboard's assembler: a DeepRacer run folder -> one validated Record. No AWS, no network."""

__version__ = "0.1.0"

from .assemble import Overrides, assemble
from .catalog import TrackCatalog, UnknownTrackError, default_catalog
from .errors import AssemblyError
from .record import Record

__all__ = [
    "AssemblyError",
    "Overrides",
    "Record",
    "TrackCatalog",
    "UnknownTrackError",
    "__version__",
    "assemble",
    "default_catalog",
]
