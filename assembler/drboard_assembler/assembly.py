"""A run folder (or a .tar.gz of one) -> one validated Record, as a pipeline of named steps:

1. find the files (layout.py): by name, and by content where no name says;
2. read the parameters and the logs (inputs.py);
3. choose the evaluated model (choice.py), when the folder holds several models' metadata;
4. the evaluations (evaluations.py): each once, with the parameters that describe it;
5. the design (design.py): each fact from the file that describes the evaluated model;
6. the conditions (conditions.py) each evaluation ran under;
7. the record: what the evaluation names (identity.py), the training, the provenance.
"""

from __future__ import annotations

import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from pydantic import ValidationError

from . import __version__, limits
from .archive import is_archive, unpack
from .catalog import ResolvedTrack
from .choice import Model, choose_model, model_folder
from .design import Facts, NamedFile, build_design, metadata_facts, printed_facts
from .errors import AssemblyError
from .evaluations import Run, collect_runs, only_evaluation
from .identity import Identity, Overrides, choose_track, first_text, identify, names_track, training_track
from .inputs import Inputs, Loaded, Reader, read_inputs, use_params
from .layout import RunFiles, find_run_files, shallowest
from .logs import JobLog
from .params import RunParams, load_params
from .reading import from_validation_error, read_bounded
from .record import Design, Record, TrainingSummary, implausible_lap
from .training import coarser, load_training

__all__ = ["Overrides", "assemble", "planned_trials"]


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
    except ValidationError as error:  # a bound no step checked: still one clear message
        raise from_validation_error(error, str(path)) from None


def planned_trials(path: Path, evaluation: str) -> int | None:
    """How many laps the evaluation that writes this metrics file will drive: the
    ``NUMBER_OF_TRIALS`` of the evaluation parameters naming it, or None when none say.

    DeepRacer rewrites an evaluation's metrics file after every lap, so this tells a complete
    file from one still being written.
    """
    files = find_run_files(path)
    only_evaluation(files, evaluation, path.name or str(path))
    metrics = files.evaluation_metrics[0]
    params = [load_params(read_bounded(p, files.name(p), limits.MAX_SMALL_FILE_BYTES), files.name(p))
              for p in files.params]
    naming = next((p for p in params if p.kind == "evaluation" and p.metrics_file == metrics.name), None)
    trials = naming.text("NUMBER_OF_TRIALS") if naming else None
    return int(trials) if trials and trials.isdigit() and len(trials) <= 6 else None


def _archive_stem(path: Path) -> str:
    name = path.name
    for suffix in (".tar.gz", ".tgz", ".tar"):
        if name.lower().endswith(suffix):
            return name[: -len(suffix)]
    return name


@dataclass(frozen=True)
class _Job:
    """One assembly: the run folder, how the racer named it, and what they asked for."""

    where: str
    overrides: Overrides
    default_model: str
    evaluation: str | None


def _assemble_folder(root: Path, where: str, overrides: Overrides, default_model: str,
                     evaluation: str | None) -> Record:
    job = _Job(where, overrides, default_model, evaluation)
    files = _find_files(root, job)
    reader = Reader(files)
    inputs = read_inputs(files, reader)
    model = choose_model(files, inputs, reader, where, overrides.model)
    runs = _evaluations(files, inputs, model, reader, job)
    design = _design(files, inputs, model, runs, reader)
    return _record(files, inputs, model, runs, design, reader, job)


# ---------------------------------------------------------------- 1. find the files

def _find_files(root: Path, job: _Job) -> RunFiles:
    files = find_run_files(root)
    _refuse_several_runs(files, job.where)
    if job.evaluation is not None:
        only_evaluation(files, job.evaluation, job.where)
    return files


def _refuse_several_runs(files: RunFiles, where: str) -> None:
    """A folder of several runs' folders (each with its model and its evaluation) is refused:
    one push is one run."""
    with_model = {files.top_folder(p) for p in files.model_metadata + files.params}
    with_evaluation = {files.top_folder(p) for p in files.evaluation_metrics + files.logs}
    runs = sorted(name for name in with_model & with_evaluation if name is not None)
    if len(runs) > 1 and None not in with_model:
        shown = ", ".join(runs[:10]) + (f" and {len(runs) - 10} more" if len(runs) > 10 else "")
        raise AssemblyError(where, "", f"holds {len(runs)} runs ({shown}); push one run per path, "
                            f"e.g. drboard push {where.rstrip('/')}/*/")


# ---------------------------------------------------------------- 4. the evaluations

def _evaluations(files: RunFiles, inputs: Inputs, model: Model, reader: Reader, job: _Job) -> list[Run]:
    runs = collect_runs(files, inputs, model, reader, job.evaluation)
    if not runs:
        raise _no_evaluation(inputs, job.where)
    kept = _on_the_track(runs, choose_track(_describing(runs, inputs), job.overrides), job.where)
    if len(kept) > limits.MAX_EVALUATION_RUNS:
        raise AssemblyError(job.where, "evaluation metrics", f"{len(kept)} evaluation runs, over the "
                            f"limit of {limits.MAX_EVALUATION_RUNS}")
    return kept


def _on_the_track(runs: list[Run], track: ResolvedTrack | None, where: str) -> list[Run]:
    """The runs on the chosen track (all of them when no track is chosen yet)."""
    if track is None:
        return runs
    kept = [run for run in runs if run.params is None or names_track(run.params, track)]
    if not kept:
        worlds = sorted({world for run in runs
                         if run.params is not None and (world := run.params.text("WORLD_NAME"))})
        raise AssemblyError(where, "WORLD_NAME", f"no evaluation ran on {track.track_id}; the "
                            f"evaluation parameters name {', '.join(worlds)}", flag="--track")
    return kept


def _describing(runs: list[Run], inputs: Inputs) -> list[RunParams]:
    """The parameters that describe the runs; without a params file per run, a lone evaluation
    params file describes the folder's runs."""
    described = [run.params for run in runs if run.params is not None]
    evaluation_params = [p for p in inputs.params if p.kind == "evaluation"]
    return described or (evaluation_params if len(evaluation_params) == 1 else [])


def _no_evaluation(inputs: Inputs, where: str) -> AssemblyError:
    unread = [log for log in inputs.logs if log.unread_format is not None and log.job != "training"]
    if unread:
        log = unread[0]
        return AssemblyError(where, log.name, f"is {log.unread_format}, which drboard does not read; "
                             "it needs the evaluation's metrics file (metrics/evaluation/*.json) or "
                             "its log as the simulation wrote it")
    return AssemblyError(where, "evaluation", "there is no evaluation in it: no evaluation "
                         "metrics file (metrics/evaluation/*.json or metrics/EvaluationMetrics-"
                         "*.json) and no evaluation log")


# ---------------------------------------------------------------- 5. the design

def _design(files: RunFiles, inputs: Inputs, model: Model, runs: list[Run], reader: Reader) -> Design:
    metadata = _metadata(model, reader)
    hyper = _hyperparameters_file(files, model, reader)
    training_logs = _training_logs(files, inputs, model)
    design = build_design(metadata_facts(_named(metadata)) if metadata else None,
                          _first_printed([run.log for run in runs if run.log is not None]),
                          _first_printed(training_logs), _named(hyper) if hyper else None,
                          next((log for log in training_logs if log.hyperparameters is not None), None))
    _use_sources(design, [read for read in (metadata, hyper) if read is not None], inputs.logs, reader)
    return design


def _training_logs(files: RunFiles, inputs: Inputs, model: Model) -> list[JobLog]:
    """The logs of the evaluated model's training jobs."""
    return [log for log in inputs.logs if log.job == "training" and model.owns(files.root / log.name)]


def _hyperparameters_file(files: RunFiles, model: Model, reader: Reader) -> Loaded | None:
    path = shallowest(model.own(files.hyperparameters), files.root)
    return reader.load(path, limits.MAX_SMALL_FILE_BYTES) if path is not None else None


def _first_printed(logs: list[JobLog]) -> Facts | None:
    """What the first of the logs that printed anything of its model printed of it."""
    return next((facts for log in logs if (facts := printed_facts(log)) is not None), None)


def _metadata(model: Model, reader: Reader) -> Loaded | None:
    return reader.load(model.metadata, limits.MAX_SMALL_FILE_BYTES) if model.metadata is not None else None


def _named(loaded: Loaded) -> NamedFile:
    return NamedFile(loaded.name, loaded.data)


def _use_sources(design: Design, files: list[Loaded], logs: list[JobLog], reader: Reader) -> None:
    """Note the files the design's facts came from, and only those."""
    assert design.sources is not None
    used = {name for name in design.sources.model_dump().values() if name}
    for loaded in files:
        if loaded.name in used:
            role = "hyperparameters" if loaded.name == design.sources.hyperparameters else "model_metadata"
            reader.use(role, loaded)
    for log in logs:
        if log.name in used:
            reader.use_log(log)


# ---------------------------------------------------------------- 7. the record

def _record(files: RunFiles, inputs: Inputs, model: Model, runs: list[Run], design: Design,
            reader: Reader, job: _Job) -> Record:
    describing = _describing(runs, inputs)
    evaluation = [run.params for run in runs if run.params is not None] or describing
    training = inputs.training_params
    identity = identify(choose_track(describing, job.overrides), evaluation, training, job.overrides,
                        job.where, _default_model(files, model, job))
    _refuse_impossible_laps(identity, runs, design)
    summary = _training(files, model, reader, first_text(training, "WORLD_NAME"))
    use_params(reader, inputs, evaluation + training)
    for run in runs:
        if run.log is not None:
            reader.use_log(run.log)
    return _build(files, identity, runs, design, summary, reader, job.where)


def _default_model(files: RunFiles, model: Model, job: _Job) -> str:
    """The model's name where no parameter gives it: its folder's, when it is one of several."""
    if model.others and model.metadata is not None and model_folder(model.metadata) != files.root:
        return model_folder(model.metadata).name
    return job.default_model


def _refuse_impossible_laps(identity: Identity, runs: list[Run], design: Design) -> None:
    problem = implausible_lap(identity.track.track_id, design.max_speed, [run.run for run in runs])
    if problem:
        raise AssemblyError(problem.run.source,
                            f"metrics[{problem.lap_index}].elapsed_time_in_milliseconds", problem.message)


def _training(files: RunFiles, model: Model, reader: Reader, world: str | None) -> TrainingSummary | None:
    paths = sorted(model.own(files.training_metrics))
    if not paths:
        return None
    return load_training(_distinct_training_files(paths, reader), training_track(world))


def _distinct_training_files(paths: list[Path], reader: Reader) -> Iterator[tuple[bytes, str]]:
    """Each training metrics file once (a copy of one worker's file counts once), one at a time."""
    seen: set[str] = set()
    for path in paths:
        loaded = reader.load(path, limits.MAX_TRAINING_FILE_BYTES)
        if loaded.sha256 not in seen:
            seen.add(loaded.sha256)
            reader.use("training_metrics", loaded)
            yield loaded.data, loaded.name


def _fitted(record: Record) -> Record:
    """The record within TARGET_RECORD_BYTES where a coarser training curve makes it fit (many
    runs and laps may still take it past, up to MAX_RECORD_BYTES)."""
    while (len(record.model_dump_json()) > limits.TARGET_RECORD_BYTES and record.training is not None
           and len(record.training.curve) > limits.MIN_CURVE_POINTS):
        training = record.training.model_copy(update={"curve": coarser(record.training.curve)})
        fields = record.model_dump(exclude={"submission_id", "training"})
        record = Record.build(**fields, training=training)
    return record


def _build(files: RunFiles, identity: Identity, runs: list[Run], design: Design,
           training: TrainingSummary | None, reader: Reader, where: str) -> Record:
    fields = {
        "track": identity.track.track_id,
        "custom_track": identity.track.track is None,
        "direction": identity.direction,
        "racer": identity.racer,
        "model_name": identity.model_name,
        "race_type": identity.race_type,
        "source_layout": files.layout,
        "assembler_version": __version__,
        "evaluations": [run.run for run in runs],
        "design": design,
        "training": training,
        "provenance": reader.provenance,
    }
    try:
        record = _fitted(Record.build(**fields))
    except ValidationError as error:
        raise from_validation_error(error, where) from None
    size = len(record.model_dump_json())
    if size > limits.MAX_RECORD_BYTES:
        raise AssemblyError(where, "record", f"is {size} bytes, over the "
                            f"{limits.MAX_RECORD_BYTES} limit (too many laps or runs)")
    return record
