"""Build valid Records in code, for tests that need a run without reading files.

``make_record(racer="Ada", laps=[(12000, 100), (13000, 100)])`` gives a record with one
evaluation run of those laps. A lap is ``(time_ms, completion_pct)`` or
``(time_ms, completion_pct, status)``; the status defaults to "Lap complete" at 100 % and
"Off track" below. ``runs=[[...], [...]]`` gives several evaluation runs instead of ``laps``.
The submission id is computed from the content, so two calls with the same arguments give the
same record (a duplicate), and any difference in racer, model or laps gives a new one. Each
racer's laps are numbered from a trial of their own, so two racers' runs of equal times are two
runs, not a copy (`copy_of` gives a copy).
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from typing import Literal

from drboard_assembler.catalog import default_catalog
from drboard_assembler.record import (
    Action,
    ActionSpace,
    Design,
    EvaluationRun,
    Hyperparameters,
    Lap,
    RaceType,
    Record,
    SourceFile,
    SourceLayout,
)

LapSpec = tuple[int, float] | tuple[int, float, str]

DEFAULT_LAPS: tuple[LapSpec, ...] = ((12000, 100), (13000, 100))


def make_laps(specs: Sequence[LapSpec], first_trial: int = 1) -> list[Lap]:
    laps = []
    for trial, spec in enumerate(specs, start=first_trial):
        time_ms, completion = spec[0], spec[1]
        status = spec[2] if len(spec) > 2 else ("Lap complete" if completion >= 100 else "Off track")
        laps.append(Lap(trial=trial, time_ms=time_ms, completion_pct=completion, status=status))
    return laps


def make_run(specs: Sequence[LapSpec], source: str = "metrics/evaluation/eval-1.json",
             first_trial: int = 1) -> EvaluationRun:
    return EvaluationRun.from_laps(source, make_laps(specs, first_trial))


def racer_trial(racer: str) -> int:
    """Where a racer's trials start: Ada's at 1, everyone else's at a number of their own."""
    if racer == "Ada":
        return 1
    return 1 + int(hashlib.sha256(racer.encode()).hexdigest()[:6], 16) % 90_000


def make_design(max_speed: float = 3.0, algorithm: Literal["clipped_ppo", "sac"] = "clipped_ppo") -> Design:
    actions = [
        Action(steering_angle=-30.0, speed=max_speed / 2, index=0),
        Action(steering_angle=0.0, speed=max_speed, index=1),
        Action(steering_angle=30.0, speed=max_speed / 2, index=2),
    ]
    return Design(
        algorithm=algorithm,
        action_space=ActionSpace(type="discrete", actions=actions, max_speed=max_speed,
                                 max_steering=30.0),
        sensors=["FRONT_FACING_CAMERA"],
        neural_network="DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        metadata_version="5",
        hyperparameters=Hyperparameters(batch_size=64, discount_factor=0.99, lr=0.0003,
                                        loss_type="huber", num_epochs=10),
    )


def _source(role: str, path: str) -> SourceFile:
    return SourceFile.model_validate({
        "role": role, "path": path, "sha256": hashlib.sha256(path.encode()).hexdigest(), "bytes": 100,
    })


def make_record(
    racer: str = "Ada",
    laps: Sequence[LapSpec] = DEFAULT_LAPS,
    *,
    runs: Sequence[Sequence[LapSpec]] | None = None,
    track: str = "reInvent2019_track",
    direction: Literal["cw", "ccw"] | None = None,
    race_type: RaceType = RaceType.TIME_TRIAL,
    max_speed: float = 3.0,
    model: str = "m1",
) -> Record:
    """A valid record; a track that is not in the catalog is taken as a custom track."""
    specs = list(runs) if runs is not None else [laps]
    evaluations = [make_run(spec, f"metrics/evaluation/eval-{n}.json", racer_trial(racer))
                   for n, spec in enumerate(specs, start=1)]
    provenance = [_source("model_metadata", "model_metadata.json"),
                  _source("hyperparameters", "ip/hyperparameters.json")]
    provenance += [_source("evaluation_metrics", run.source) for run in evaluations]
    return Record.build(
        track=track,
        custom_track=not default_catalog().is_official(track),
        direction=direction,
        racer=racer,
        model_name=model,
        race_type=race_type,
        source_layout=SourceLayout.PLAIN,
        assembler_version="test",
        evaluations=evaluations,
        design=make_design(max_speed),
        training=None,
        provenance=provenance,
    )


def copy_of(record: Record, racer: str) -> Record:
    """The record renamed to another racer and re-hashed: a copied run."""
    fields = record.model_dump(exclude={"submission_id"})
    return Record.build(**(fields | {"racer": racer}))
