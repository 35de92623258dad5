"""Step 3, choose the evaluated model: which model_metadata.json (and so which folder's
hyperparameters, training metrics and training logs) describes the model the evaluation ran.

A run folder usually holds one model (its ``model_metadata.json`` perhaps twice, at the top and
in ``model/``). When it holds several models' metadata, the evaluation names the one it ran: its
``MODEL_NAME`` (a folder of that name), the ``MODEL_METADATA_FILE_S3_KEY`` or ``MODEL_S3_PREFIX``
of its parameters, or the metadata key its log says it loaded. A folder whose evaluation names
none of them is refused, with the folders to choose from.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from . import limits
from .errors import AssemblyError
from .inputs import Inputs, Reader
from .layout import RunFiles
from .params import RunParams

#: Path parts that name no model in particular.
_GENERIC_PARTS = {"model", "models", "sagemaker-robomaker-artifacts", "sagemaker-artifacts",
                  "rl-deepracer-sagemaker", "model_metadata.json", ""}


@dataclass(frozen=True)
class Model:
    """The evaluated model: its metadata file (None: the folder holds none) and the folders of
    the other models the run folder holds, whose files describe those models, not this one."""

    metadata: Path | None
    others: tuple[Path, ...] = ()

    def owns(self, path: Path) -> bool:
        return not any(path.is_relative_to(folder) for folder in self.others)

    def own(self, paths: Iterable[Path]) -> list[Path]:
        return [path for path in paths if self.owns(path)]


def choose_model(files: RunFiles, inputs: Inputs, reader: Reader, where: str,
                 model_name: str | None = None) -> Model:
    candidates = _distinct_metadata(files, reader)
    if len(candidates) <= 1:
        return Model(next(iter(candidates), None))
    chosen = _best_named(files, candidates, _names(inputs.evaluation_params, inputs, model_name))
    if not chosen:  # the training's parameters, of the folder's model, name its metadata
        chosen = _best_named(files, candidates, _names(inputs.training_params, inputs, None))
    if len(chosen) != 1:
        raise _unnamed(files, candidates, where)
    others = {model_folder(path) for path in candidates if path != chosen[0]}
    return Model(chosen[0], tuple(sorted(folder for folder in others
                                         if not chosen[0].is_relative_to(folder))))


def model_folder(path: Path) -> Path:
    """The folder a model_metadata.json describes: its own, or its parent's for ``model/``."""
    return path.parent.parent if path.parent.name == "model" else path.parent


def _distinct_metadata(files: RunFiles, reader: Reader) -> list[Path]:
    """The metadata files of distinct content, the one nearest the top of each (a copy of one
    model's metadata in ``model/`` is the same model)."""
    by_content: dict[str, Path] = {}
    for path in sorted(files.model_metadata, key=lambda p: (len(p.parts), p.as_posix())):
        by_content.setdefault(reader.load(path, limits.MAX_SMALL_FILE_BYTES).sha256, path)
    return list(by_content.values())


def _best_named(files: RunFiles, candidates: list[Path], names: list[PurePosixPath]) -> list[Path]:
    """The metadata files the names fit best (none when no name fits any)."""
    scores = {path: max((_score(files, path, name) for name in names), default=0) for path in candidates}
    best = max(scores.values())
    return [path for path, score in scores.items() if score == best] if best else []


def _names(described: list[RunParams], inputs: Inputs, model_name: str | None) -> list[PurePosixPath]:
    """What the parameters (and, for an evaluation, its logs) say of the model, as paths whose
    parts name it."""
    texts: list[str | None] = [model_name]
    for params in described:
        texts += [params.text(key) for key in ("MODEL_NAME", "MODEL_METADATA_FILE_S3_KEY",
                                               "MODEL_S3_PREFIX")]
    if described and described[0].kind == "evaluation":
        texts += [log.metadata_key for log in inputs.logs if log.is_evaluation]
    return [PurePosixPath(text.replace("\\", "/")) for text in texts if text]


#: A name that names the model's folder outranks any match of the metadata file's path alone.
_FOLDER_NAMED = 1000


def _score(files: RunFiles, metadata: Path, name: PurePosixPath) -> int:
    """How well a name fits a metadata file: a name that holds the model folder's name fits
    best; else the number of the file path's last parts the name ends with (an S3 key)."""
    folder = PurePosixPath(files.name(model_folder(metadata))) if model_folder(metadata) != files.root \
        else PurePosixPath()
    folder_parts = [part for part in folder.parts if part not in _GENERIC_PARTS]
    if folder_parts and folder_parts[-1] in name.parts:
        return _FOLDER_NAMED
    path_parts = PurePosixPath(files.name(metadata)).parts
    matching = 0
    while (matching < min(len(path_parts), len(name.parts))
           and path_parts[-1 - matching] == name.parts[-1 - matching]):
        matching += 1
    return matching if matching > 1 or len(path_parts) == 1 else 0


def _unnamed(files: RunFiles, candidates: list[Path], where: str) -> AssemblyError:
    listing = ", ".join(files.name(path) for path in candidates[:10])
    if len(candidates) > 10:
        listing += f" and {len(candidates) - 10} more"
    folders = sorted({files.name(model_folder(path)) for path in candidates
                      if model_folder(path) != files.root})
    problem = (f"holds the metadata of {len(candidates)} models ({listing}) and nothing in the "
               "evaluation's files names the one it ran")
    if not folders:
        return AssemblyError(where, "model_metadata.json", problem + ": keep only the evaluated model's")
    return AssemblyError(where, "model_metadata.json",
                         f"{problem}: name it (--model {PurePosixPath(folders[0]).name}) or push "
                         f"the evaluated model's folder with the evaluation in it (e.g. drboard push "
                         f"{where.rstrip('/')}/{folders[0]})")
