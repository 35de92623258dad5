"""Step 4, the evaluations: each evaluation the run folder holds, once, with the parameters
that describe it.

An evaluation may be seen several times: as its metrics file, as a renamed copy of it, and as the
log of the job that wrote it. They are one evaluation when they hold the same laps (times within a
few simulation steps, same completion): a copy counts once, and a log adds its parameters to the
metrics file it wrote. A log whose laps no metrics file holds is an evaluation of its own (a
log-only download, or a console download's leaderboard races, which come without their metrics
files) unless its parameters name a metrics file the folder holds.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from . import limits
from .choice import Model
from .conditions import conditions_of
from .errors import AssemblyError
from .inputs import Inputs, Reader
from .layout import RunFiles
from .logs import JobLog
from .metrics import load_evaluation
from .params import RunParams
from .record import EvaluationRun, Lap

#: How far a lap's time read from a log may stray from the metrics file's: the log's first step
#: comes a step after the lap starts, and steps are 1/15 s (real pairs differ by under 25 ms;
#: two evaluations of one model, by 5 ms and more on some of their laps).
LAP_TIME_TOLERANCE_MS = 100
#: How far a lap's first logged step may be from the start the metrics file gives it.
LAP_START_TOLERANCE_MS = 500


@dataclass(frozen=True)
class Run:
    """One evaluation: its laps, the parameters that describe it, and its log."""

    run: EvaluationRun
    params: RunParams | None = None
    log: JobLog | None = None


def collect_runs(files: RunFiles, inputs: Inputs, model: Model, reader: Reader,
                 only: str | None = None) -> list[Run]:
    """The evaluations of the run folder, each once. ``only`` names the one evaluation metrics
    file to take (logs then add nothing but its parameters)."""
    runs = _metrics_runs(files, inputs, model, reader, only)
    runs = _with_logs(runs, [log for log in inputs.evaluation_logs if model.owns(files.root / log.name)],
                      present={path.name for path in files.evaluation_metrics}, logs_are_runs=only is None)
    return [_with_conditions(run) for run in _named(runs, inputs)]


def only_evaluation(files: RunFiles, evaluation: str, where: str) -> None:
    """Keep only the named evaluation metrics file."""
    for path in files.evaluation_metrics:
        if files.name(path) == evaluation:
            files.evaluation_metrics = [path]
            return
    raise AssemblyError(where, evaluation, "no such evaluation metrics file in the run folder")


def _metrics_runs(files: RunFiles, inputs: Inputs, model: Model, reader: Reader,
                  only: str | None) -> list[Run]:
    runs: list[Run] = []
    seen: set[str] = set()
    for path in model.own(files.evaluation_metrics):
        loaded = reader.load(path, limits.MAX_EVALUATION_FILE_BYTES)
        if loaded.sha256 in seen:
            continue  # a copy of a file read already
        seen.add(loaded.sha256)
        run = load_evaluation(loaded.data, loaded.name)
        if any(run.laps == earlier.run.laps for earlier in runs):
            continue  # the same evaluation, written again
        reader.use("evaluation_metrics", loaded)
        runs.append(Run(run, _params_naming(path.name, inputs.evaluation_params)))
    return runs


def _with_logs(runs: list[Run], logs: list[JobLog], *, present: set[str], logs_are_runs: bool) -> list[Run]:
    """Each log joined to the metrics run of its laps; a log of laps no metrics file holds as a
    run of its own."""
    for log in logs:
        laps = log.laps()
        index = _run_of(log, laps, runs)
        if index is not None:
            runs[index] = replace(runs[index], log=log,
                                  params=runs[index].params or _evaluation_params(log))
        elif logs_are_runs and not _names_present_file(log, present):
            runs.append(Run(EvaluationRun.from_laps(log.name, laps), _evaluation_params(log), log))
    return runs


def _run_of(log: JobLog, laps: list[Lap], runs: list[Run]) -> int | None:
    """The run (not joined to a log yet) the log wrote: the one whose file its parameters name,
    else the one of its laps."""
    free = [i for i, run in enumerate(runs) if run.log is None]
    named = next((i for i in free if _source_name(runs[i]) == _named_file(log)), None)
    return named if named is not None else next((i for i in free if _wrote(log, laps, runs[i].run)), None)


def _names_present_file(log: JobLog, present: set[str]) -> bool:
    named = _named_file(log)
    return named is not None and named in present


def _named_file(log: JobLog) -> str | None:
    """The metrics file the log's job wrote, as its parameters name it."""
    return log.params.metrics_file if log.params is not None else None


def _source_name(run: Run) -> str:
    return run.run.source.rsplit("/", 1)[-1]


def _evaluation_params(log: JobLog) -> RunParams | None:
    return log.params if log.params is not None and log.params.kind == "evaluation" else None


def _named(runs: list[Run], inputs: Inputs) -> list[Run]:
    """Whether the folder's evaluation parameters name each run's file: a lone params file that
    names no file describes the folder's runs; parameters that name only files the folder does
    not hold describe another run (the board flags it)."""
    foreign = _params_name_other_files(runs, inputs.evaluation_params)
    lone = _lone_params(inputs)
    named = []
    for run in runs:
        if run.params is not None or foreign:
            run = replace(run, run=run.run.model_copy(update={"named_by_params": run.params is not None}))
        if run.params is None and lone is not None:
            run = replace(run, params=lone)
        named.append(run)
    return named


def _params_name_other_files(runs: list[Run], evaluation_params: list[RunParams]) -> bool:
    named_files = {p.metrics_file for p in evaluation_params if p.metrics_file}
    described = {_source_name(run) for run in runs if run.params is not None}
    return bool(named_files) and not named_files & described


def _lone_params(inputs: Inputs) -> RunParams | None:
    """The folder's one evaluation params file, when it names no metrics file of its own."""
    evaluation_params = inputs.evaluation_params
    if not inputs.params or len(evaluation_params) != 1:
        return None
    return evaluation_params[0] if evaluation_params[0].metrics_file is None else None


def _with_conditions(run: Run) -> Run:
    conditions = conditions_of(run.params)
    if conditions is None:
        return run
    return replace(run, run=run.run.model_copy(update={"conditions": conditions}))


def _params_naming(metrics_name: str, evaluation_params: list[RunParams]) -> RunParams | None:
    return next((p for p in evaluation_params if p.metrics_file == metrics_name), None)


def _wrote(log: JobLog, laps: list[Lap], run: EvaluationRun) -> bool:
    """Whether the log is of the evaluation that wrote the run's metrics: as many laps, each of
    the same status and completion, and of the same time and (where the metrics file says it)
    start, a step or so apart."""
    starts = log.lap_starts_ms()
    return len(run.laps) == len(laps) and all(
        abs(lap.time_ms - logged.time_ms) <= LAP_TIME_TOLERANCE_MS
        and abs(lap.completion_pct - logged.completion_pct) <= 1.0
        and lap.status.strip().lower() == logged.status.lower()
        and (lap.started_ms is None or abs(lap.started_ms - start) <= LAP_START_TOLERANCE_MS)
        for lap, logged, start in zip(run.laps, laps, starts, strict=True))
