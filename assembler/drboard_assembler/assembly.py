"""A run folder (or a .tar.gz of one) -> one validated Record."""

from __future__ import annotations

import hashlib
import json
import tempfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from pydantic import ValidationError

from . import __version__, limits
from .archive import is_archive, unpack
from .catalog import ResolvedTrack, UnknownTrackError, default_catalog
from .design import load_design
from .errors import AssemblyError
from .layout import RunFiles, find_run_files, shallowest
from .logs import JobLog, read_log
from .metrics import load_evaluation, load_training
from .params import RunParams, load_params
from .reading import from_validation_error, read_bounded
from .record import Design, EvaluationRun, RaceType, Record, SourceFile, implausible_lap


@dataclass(frozen=True)
class Overrides:
    """Values given on the command line; they win over what the files say."""

    track: str | None = None
    racer: str | None = None
    model: str | None = None
    custom_track: bool = False
    race_type: str | None = None


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
                # Named as the folder it unpacks to, so that the folder and its archive are one run.
                model = root.name if root != Path(scratch) else _archive_stem(path)
                return _assemble_folder(root, str(path), overrides, model, evaluation)
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
        self.note(role, name, hashlib.sha256(data).hexdigest(), len(data))
        return data

    def read_new(self, path: Path, role: str, max_bytes: int) -> bytes | None:
        """The file's bytes, or None when a file of the same role and content was read already
        (a download that holds the same evaluation twice)."""
        data = read_bounded(path, self.files.name(path), max_bytes)
        digest = hashlib.sha256(data).hexdigest()
        if any(s.role == role and s.sha256 == digest for s in self.provenance):
            return None
        self.note(role, self.files.name(path), digest, len(data))
        return data

    def note(self, role: str, name: str, sha256: str, size: int) -> None:
        self.provenance.append(SourceFile.model_validate({
            "role": role, "path": name[: limits.MAX_TEXT_CHARS], "sha256": sha256,
            "bytes": min(size, limits.MAX_TRAINING_FILE_BYTES),
        }))


def _assemble_folder(root: Path, where: str, overrides: Overrides, default_model: str,
                     evaluation: str | None) -> Record:
    files = find_run_files(root)
    _refuse_several_runs(files, where)
    if evaluation is not None:
        files.evaluation_metrics = [_only_evaluation(files, evaluation, where)]
    reader = _Reader(files)
    logs = [read_log(p, files.name(p)) for p in sorted(files.logs)[: limits.MAX_LOG_FILES]]
    evaluation_logs = [log for log in logs if log.is_evaluation and log.laps()]
    if not files.evaluation_metrics and not (evaluation is None and evaluation_logs):
        raise AssemblyError(where, "evaluation", "there is no evaluation in it: no evaluation "
                            "metrics file (metrics/evaluation/*.json or metrics/EvaluationMetrics-"
                            "*.json) and no evaluation log")

    params = [
        load_params(reader.read(p, "training_params", limits.MAX_SMALL_FILE_BYTES), files.name(p))
        for p in files.params
    ]
    logged = [log.params for log in logs if log.params is not None]
    training_params = [p for p in params + logged if p.kind == "training"]
    evaluation_params = [p for p in params + logged if p.kind == "evaluation"]
    design = _design(files, logs, evaluation_params + training_params, reader, where)

    runs: list[tuple[EvaluationRun, RunParams | None]] = []
    # Parameters that name only metrics files the folder does not hold describe another run.
    named_files = {p.metrics_file for p in evaluation_params if p.metrics_file}
    foreign = bool(named_files) and not named_files & {p.name for p in files.evaluation_metrics}
    for path in files.evaluation_metrics:
        data = reader.read_new(path, "evaluation_metrics", limits.MAX_EVALUATION_FILE_BYTES)
        if data is None:
            continue
        run = load_evaluation(data, files.name(path))
        named = _params_for(path.name, evaluation_params)
        if named is not None or foreign:
            run = run.model_copy(update={"named_by_params": named is not None})
        runs.append((run, named))
    # Laps from the evaluation logs whose metrics file is not present (a log-only download, or
    # a console download's leaderboard races, which come without their metrics files).
    present = {p.name for p in files.evaluation_metrics}
    for log in evaluation_logs if evaluation is None else []:
        metrics_file = log.params.metrics_file if log.params is not None else None
        if not present or (metrics_file is not None and metrics_file not in present):
            _note_log(reader, log)
            runs.append((EvaluationRun.from_laps(log.name, log.laps()), log.params))

    track = _choose_track(runs, evaluation_params, overrides)
    kept = [(run, p) for run, p in runs if track is None or p is None or _names_track(p, track)]
    if not kept and track is not None:
        worlds = sorted({w for _, p in runs if p is not None and (w := p.text("WORLD_NAME"))})
        raise AssemblyError(where, "WORLD_NAME", f"no evaluation ran on {track.track_id}; the "
                            f"evaluation parameters name {', '.join(worlds)}", flag="--track")
    if len(kept) > limits.MAX_EVALUATION_RUNS:
        raise AssemblyError(where, "evaluation metrics",
                            f"{len(kept)} evaluation runs, over the limit of "
                            f"{limits.MAX_EVALUATION_RUNS}")
    run_params = [p for _, p in kept if p is not None] or evaluation_params
    described_by = run_params + training_params

    racer = overrides.racer or _first_text(described_by, "RACER_NAME", "DISPLAY_NAME", "CAR_NAME")
    race_type = _race_type(run_params + training_params, overrides, where)
    missing = [(field, flag) for field, flag, known in (
        ("WORLD_NAME", "--track", track is not None),
        ("RACER_NAME", "--racer", bool(racer)),
        ("RACE_TYPE", "--race-type", race_type is not None),
    ) if not known]
    if missing:
        raise AssemblyError(where, ", ".join(f for f, _ in missing),
                            "the run's files do not say", flag=", ".join(f for _, f in missing))
    assert track is not None and racer and race_type is not None
    model = overrides.model or _model_name(described_by, default_model)

    training = None
    if files.training_metrics:
        training_track = _training_track(_first_text(training_params, "WORLD_NAME"))
        training = load_training(
            ((reader.read(p, "training_metrics", limits.MAX_TRAINING_FILE_BYTES), files.name(p))
             for p in sorted(files.training_metrics)),
            training_track,
        )

    problem = implausible_lap(track.track_id, design.action_space.max_speed, [r for r, _ in kept])
    if problem:
        raise AssemblyError(problem.run.source,
                            f"metrics[{problem.lap_index}].elapsed_time_in_milliseconds", problem.message)
    for log in logs:
        if log.params is not None and log.params in described_by:
            _note_log(reader, log)
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


def _refuse_several_runs(files: RunFiles, where: str) -> None:
    """A folder of several runs' folders (each with its model and its evaluation) is refused:
    one push is one run."""
    def top(path: Path) -> str | None:
        parts = path.relative_to(files.root).parts
        return parts[0] if len(parts) > 1 else None

    with_model = {top(p) for p in files.model_metadata + files.params}
    with_evaluation = {top(p) for p in files.evaluation_metrics + files.logs}
    runs = sorted(name for name in with_model & with_evaluation if name is not None)
    if len(runs) > 1 and None not in with_model:
        shown = ", ".join(runs[:10]) + (f" and {len(runs) - 10} more" if len(runs) > 10 else "")
        raise AssemblyError(where, "", f"holds {len(runs)} runs ({shown}); push one run per path, "
                            f"e.g. drboard push {where.rstrip('/')}/*/")


def _design(files: RunFiles, logs: list[JobLog], params: list[RunParams], reader: _Reader,
            where: str) -> Design:
    """The model's design: model_metadata.json (the one the parameters name, when the folder
    holds different ones), else what the job's logs printed."""
    hyper: bytes | None
    hyper_path = shallowest(files.hyperparameters, files.root)
    if hyper_path is not None:
        hyper = reader.read(hyper_path, "hyperparameters", limits.MAX_SMALL_FILE_BYTES)
        hyper_name = files.name(hyper_path)
    else:
        printed = next((log for log in logs if log.hyperparameters is not None), None)
        hyper = json.dumps(printed.hyperparameters).encode() if printed else None
        hyper_name = printed.name if printed else "hyperparameters.json"
        if printed:
            _note_log(reader, printed)
    metadata_path = _model_metadata(files, params, where)
    if metadata_path is not None:
        return load_design(reader.read(metadata_path, "model_metadata", limits.MAX_SMALL_FILE_BYTES),
                           files.name(metadata_path), hyper, hyper_name)
    for log in sorted(logs, key=lambda log: not log.is_evaluation):
        if (metadata := log.metadata()) is not None:
            _note_log(reader, log)
            return load_design(metadata, log.name, hyper, hyper_name)
    raise AssemblyError(where, "model_metadata.json",
                        "not found in the run folder (nor an action space in its logs)")


def _note_log(reader: _Reader, log: JobLog) -> None:
    if not any(source.path == log.name for source in reader.provenance):
        role = "simulation_log" if log.is_evaluation or log.episodes else "training_log"
        reader.note(role, log.name, log.sha256, log.size)


def _model_metadata(files: RunFiles, params: list[RunParams], where: str) -> Path | None:
    distinct: dict[str, Path] = {}
    for path in sorted(files.model_metadata, key=lambda p: (len(p.parts), p.as_posix())):
        digest = hashlib.sha256(read_bounded(path, files.name(path),
                                             limits.MAX_SMALL_FILE_BYTES)).hexdigest()
        distinct.setdefault(digest, path)
    if len(distinct) <= 1:
        return next(iter(distinct.values()), None)
    keys = [k for p in params if (k := p.text("MODEL_METADATA_FILE_S3_KEY"))]
    # The key is an S3 path: the file it names is the one matching the most of its tail.
    named = sorted((len(path.relative_to(files.root).parts), files.name(path), path)
                   for path in distinct.values()
                   if any(("/" + key).endswith("/" + files.name(path)) for key in keys))
    if named and (len(named) == 1 or named[-1][0] > named[-2][0]):
        return named[-1][2]
    raise AssemblyError(where, "model_metadata.json",
                        "the folder holds different ones (" +
                        ", ".join(files.name(p) for p in distinct.values()) +
                        "); push the folder of one model")


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
                  evaluation_params: list[RunParams], overrides: Overrides) -> ResolvedTrack | None:
    if overrides.track:
        return _resolve(overrides.track, custom=overrides.custom_track, source="--track")
    matched = [p for _, p in runs if p is not None]
    # Without a params file per run, a lone evaluation params file describes the folder's runs.
    candidates = matched or (evaluation_params if len(evaluation_params) == 1 else [])
    worlds = {w for p in candidates if (w := p.text("WORLD_NAME"))}
    if not worlds:
        return None
    resolved = {}
    for world in sorted(worlds):
        source = next(p.name for p in candidates if p.text("WORLD_NAME") == world)
        track = _resolve(world, custom=True, source=source)
        resolved[track.track_id] = track
    if len(resolved) > 1:
        raise AssemblyError(candidates[0].name if len(candidates) == 1 else "evaluation parameters",
                            "WORLD_NAME", f"evaluations on several tracks ({', '.join(sorted(resolved))}); "
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


#: Prefixes that name no model in particular: DeepRacer-for-Cloud's default, and the folders
#: the console and DeepRacer on AWS keep a model's artifacts in.
GENERIC_PREFIXES = {"rl-deepracer-sagemaker", "sagemaker-robomaker-artifacts", "sagemaker-artifacts"}


def _model_name(params: list[RunParams], folder: str) -> str:
    """MODEL_NAME, else the model's S3 prefix (DeepRacer-for-Cloud names its models by the
    prefix), else the folder's (or the archive's) name."""
    if name := _first_text(params, "MODEL_NAME"):
        return name
    prefix = _first_text(params, "MODEL_S3_PREFIX", "SAGEMAKER_SHARED_S3_PREFIX")
    name = PurePosixPath(prefix.strip("/")).name if prefix else ""
    if name and name not in GENERIC_PREFIXES:
        return name
    return folder


def _direction(params: list[RunParams]) -> str | None:
    for p in params:
        clockwise = p.flag("TRACK_DIRECTION_CLOCKWISE")
        if clockwise is not None:
            return "cw" if clockwise else "ccw"
    return None


def _race_type(params: list[RunParams], overrides: Overrides, where: str) -> RaceType | None:
    """The race type: --race-type, else the parameters' (a time trial where they leave it out),
    else unknown: nothing describes the run."""
    text = overrides.race_type or _first_text(params, "RACE_TYPE")
    if text is None:
        return RaceType.TIME_TRIAL if params else None
    try:
        return RaceType(text.strip().upper())
    except ValueError:
        source = "--race-type" if overrides.race_type else next(
            (p.name for p in params if p.text("RACE_TYPE")), where)
        choices = ", ".join(RaceType)
        raise AssemblyError(source, "" if overrides.race_type else "RACE_TYPE",
                            f"unknown race type {text!r} (one of {choices})") from None
