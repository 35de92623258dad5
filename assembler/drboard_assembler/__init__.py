"""drboard's assembler: a DeepRacer run folder -> one validated Record. No AWS, no network."""

__version__ = "0.1.0"

from .assemble import Overrides, assemble  # noqa: E402
from .catalog import TrackCatalog, UnknownTrackError, default_catalog  # noqa: E402
from .errors import AssemblyError  # noqa: E402
from .record import Record  # noqa: E402

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
