"""A run folder (or a .tar.gz of one) -> one validated Record."""

from __future__ import annotations

import hashlib
import tempfile
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from . import __version__, limits
from .archive import is_archive, unpack
from .catalog import ResolvedTrack, UnknownTrackError, default_catalog
from .design import load_design
from .errors import AssemblyError
from .layout import RunFiles, find_run_files, shallowest
from .metrics import load_evaluation, load_training
from .params import RunParams, load_params
from .reading import from_validation_error, read_bounded
from .record import EvaluationRun, RaceType, Record, SourceFile, implausible_lap


@dataclass(frozen=True)
class Overrides:
    """Values given on the command line; they win over what the files say."""

    track: str | None = None
    racer: str | None = None
    model: str | None = None
    custom_track: bool = False


def assemble(path: Path, overrides: Overrides | None = None, *,
             evaluation: str | None = None) -> Record:
    """Read a run folder (or a .tar.gz of one) into a record.

    ``evaluation`` names one evaluation metrics file, relative to the run folder as
    :func:`evaluation_files` lists it; the record then holds that evaluation run only, exactly as
    if the folder's other evaluation metrics files were not there.
    """
    overrides = overrides or Overrides()
    try:
        if is_archive(path):
            with tempfile.TemporaryDirectory(prefix="drboard-") as scratch:
                root = unpack(path, Path(scratch))
                return _assemble_folder(root, str(path), overrides, _archive_stem(path), evaluation)
        if not path.exists():
            raise AssemblyError(str(path), "", "does not exist")
        return _assemble_folder(path, str(path), overrides, path.resolve().name, evaluation)
    except AssemblyError as error:
        if not error.file.startswith("--"):
            error.given = str(path)
        raise


def planned_trials(path: Path, evaluation: str) -> int | None:
    """How many laps the evaluation that writes this metrics file will drive: the
    ``NUMBER_OF_TRIALS`` of the evaluation parameters naming it, or None when none say.

    DeepRacer rewrites an evaluation's metrics file after every lap, so this tells a complete
    file from one still being written.
    """
    files = find_run_files(path)
    metrics = _only_evaluation(files, evaluation, path.name or str(path))
    params = [load_params(read_bounded(p, files.name(p), limits.MAX_SMALL_FILE_BYTES), files.name(p))
              for p in files.params]
    naming = _params_for(metrics.name, [p for p in params if p.kind == "evaluation"])
    trials = naming.text("NUMBER_OF_TRIALS") if naming else None
    return int(trials) if trials and trials.isdigit() and len(trials) <= 6 else None


def _archive_stem(path: Path) -> str:
    name = path.name
    for suffix in (".tar.gz", ".tgz", ".tar"):
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return name


class _Reader:
    """Reads each input once, remembering its provenance."""

    def __init__(self, files: RunFiles) -> None:
        self.files = files
        self.provenance: list[SourceFile] = []

    def read(self, path: Path, role: str, max_bytes: int) -> bytes:
        name = self.files.name(path)
        data = read_bounded(path, name, max_bytes)
        self.provenance.append(SourceFile.model_validate({
            "role": role, "path": name[: limits.MAX_TEXT_CHARS],
            "sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data),
        }))
        return data


def _assemble_folder(root: Path, where: str, overrides: Overrides, default_model: str,
                     evaluation: str | None) -> Record:
    files = find_run_files(root)
    if evaluation is not None:
        files.evaluation_metrics = [_only_evaluation(files, evaluation, where)]
    reader = _Reader(files)

    metadata_path = shallowest(files.model_metadata, root)
    if metadata_path is None:
        raise AssemblyError(where, "model_metadata.json", "not found in the run folder")
    hyper_path = shallowest(files.hyperparameters, root)
    design = load_design(
        reader.read(metadata_path, "model_metadata", limits.MAX_SMALL_FILE_BYTES),
        files.name(metadata_path),
        reader.read(hyper_path, "hyperparameters", limits.MAX_SMALL_FILE_BYTES)
        if hyper_path else None,
        files.name(hyper_path) if hyper_path else "hyperparameters.json",
    )

    params = [
        load_params(reader.read(p, "training_params", limits.MAX_SMALL_FILE_BYTES), files.name(p))
        for p in files.params
    ]
    training_params = [p for p in params if p.kind == "training"]
    evaluation_params = [p for p in params if p.kind == "evaluation"]
    if not files.evaluation_metrics:
        raise AssemblyError(where, "evaluation metrics",
                            "no evaluation metrics file found (metrics/evaluation/*.json or "
                            "metrics/EvaluationMetrics-*.json)")
    runs: list[tuple[EvaluationRun, RunParams | None]] = []
    # Parameters that name only metrics files the folder does not hold describe another run.
    named_files = {p.metrics_file for p in evaluation_params if p.metrics_file}
    foreign = bool(named_files) and not named_files & {p.name for p in files.evaluation_metrics}
    for path in files.evaluation_metrics:
        run = load_evaluation(
            reader.read(path, "evaluation_metrics", limits.MAX_EVALUATION_FILE_BYTES),
            files.name(path),
        )
        named = _params_for(path.name, evaluation_params)
        if named is not None or foreign:
            run = run.model_copy(update={"named_by_params": named is not None})
        runs.append((run, named))

    track = _choose_track(runs, evaluation_params, overrides, where)
    kept = [(run, p) for run, p in runs if p is None or _names_track(p, track)]
    if not kept:
        worlds = sorted({w for _, p in runs if p is not None and (w := p.text("WORLD_NAME"))})
        raise AssemblyError(where, "WORLD_NAME", f"no evaluation ran on {track.track_id}; the "
                            f"evaluation parameters name {', '.join(worlds)}", flag="--track")
    if len(kept) > limits.MAX_EVALUATION_RUNS:
        raise AssemblyError(where, "evaluation metrics",
                            f"{len(kept)} evaluation runs, over the limit of "
                            f"{limits.MAX_EVALUATION_RUNS}")
    run_params = [p for _, p in kept if p is not None] or evaluation_params
    described_by = run_params + training_params

    training = None
    if files.training_metrics:
        training_track = _training_track(_first_text(training_params, "WORLD_NAME"))
        training = load_training(
            ((reader.read(p, "training_metrics", limits.MAX_TRAINING_FILE_BYTES), files.name(p))
             for p in sorted(files.training_metrics)),
            training_track,
        )

    racer = overrides.racer or _first_text(described_by, "RACER_NAME", "DISPLAY_NAME", "CAR_NAME")
    if not racer:
        raise AssemblyError(where, "RACER_NAME", "no racer name in the run's parameters",
                            flag="--racer")
    model = overrides.model or _first_text(described_by, "MODEL_NAME") or default_model
    race_type = _race_type(run_params, where)

    problem = implausible_lap(track.track_id, design.action_space.max_speed, [r for r, _ in kept])
    if problem:
        raise AssemblyError(problem.run.source,
                            f"metrics[{problem.lap_index}].elapsed_time_in_milliseconds", problem.message)
    fields = {
        "track": track.track_id,
        "custom_track": track.track is None,
        "direction": track.direction or _direction(run_params),
        "racer": racer,
        "model_name": model,
        "race_type": race_type,
        "source_layout": files.layout,
        "assembler_version": __version__,
        "evaluations": [run for run, _ in kept],
        "design": design,
        "training": training,
        "provenance": _roles(reader.provenance, params),
    }
    try:
        record = Record.build(**fields)
    except ValidationError as error:
        raise from_validation_error(error, where) from None
    size = len(record.model_dump_json())
    if size > limits.MAX_RECORD_BYTES:
        raise AssemblyError(where, "record", f"is {size} bytes, over the "
                            f"{limits.MAX_RECORD_BYTES} limit (too many laps or runs)")
    return record


def _only_evaluation(files: RunFiles, evaluation: str, where: str) -> Path:
    for path in files.evaluation_metrics:
        if files.name(path) == evaluation:
            return path
    raise AssemblyError(where, evaluation, "no such evaluation metrics file in the run folder")


def _roles(provenance: list[SourceFile], params: list[RunParams]) -> list[SourceFile]:
    kinds = {p.name: f"{p.kind}_params" for p in params}
    return [s.model_copy(update={"role": kinds[s.path]}) if s.path in kinds else s
            for s in provenance]


def _params_for(metrics_name: str, evaluation_params: list[RunParams]) -> RunParams | None:
    for params in evaluation_params:
        if params.metrics_file == metrics_name:
            return params
    return None


def _names_track(params: RunParams, track: ResolvedTrack) -> bool:
    world = params.text("WORLD_NAME")
    if world is None:
        return True
    try:
        return _resolve(world, custom=False, source=params.name).track_id == track.track_id
    except AssemblyError:
        return world == track.track_id


def _choose_track(runs: list[tuple[EvaluationRun, RunParams | None]],
                  evaluation_params: list[RunParams], overrides: Overrides,
                  where: str) -> ResolvedTrack:
    if overrides.track:
        return _resolve(overrides.track, custom=overrides.custom_track, source="--track")
    matched = [p for _, p in runs if p is not None]
    # Without a params file per run, a lone evaluation params file describes the folder's runs.
    candidates = matched or (evaluation_params if len(evaluation_params) == 1 else [])
    worlds = {w for p in candidates if (w := p.text("WORLD_NAME"))}
    if not worlds:
        raise AssemblyError(where, "WORLD_NAME",
                            "no evaluation parameters name the track", flag="--track")
    resolved = {}
    for world in sorted(worlds):
        source = next(p.name for p in candidates if p.text("WORLD_NAME") == world)
        track = _resolve(world, custom=True, source=source)
        resolved[track.track_id] = track
    if len(resolved) > 1:
        raise AssemblyError(where, "WORLD_NAME",
                            f"evaluations on several tracks ({', '.join(sorted(resolved))}); "
                            "choose one", flag="--track")
    return next(iter(resolved.values()))


def _resolve(name: str, *, custom: bool, source: str) -> ResolvedTrack:
    catalog = default_catalog()
    try:
        return catalog.resolve_custom(name) if custom else catalog.resolve(name)
    except UnknownTrackError as error:
        field = "" if source == "--track" else "WORLD_NAME"
        hint = "" if error.ambiguous or custom else "; pass --custom-track for a track of your own"
        raise AssemblyError(source, field, f"{error}{hint}") from None


def _training_track(world: str | None) -> str | None:
    if world is None:
        return None
    try:
        return default_catalog().resolve(world).track_id
    except UnknownTrackError:
        return world


def _first_text(params: list[RunParams], *keys: str) -> str | None:
    for key in keys:
        for p in params:
            if value := p.text(key):
                return value
    return None


def _direction(params: list[RunParams]) -> str | None:
    for p in params:
        clockwise = p.flag("TRACK_DIRECTION_CLOCKWISE")
        if clockwise is not None:
            return "cw" if clockwise else "ccw"
    return None


def _race_type(params: list[RunParams], where: str) -> RaceType:
    text = _first_text(params, "RACE_TYPE")
    if text is None:
        return RaceType.TIME_TRIAL
    try:
        return RaceType(text.upper())
    except ValueError:
        source = next((p.name for p in params if p.text("RACE_TYPE")), where)
        raise AssemblyError(source, "RACE_TYPE", f"unknown race type {text!r}") from None
