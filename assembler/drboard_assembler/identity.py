"""What the evaluation names: its track (and direction), racer, race type and model, from the
evaluation's parameters first and the training's after (the racer and the model are one
account's and one model's; the track is the evaluation's own, never the training's).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import PurePosixPath

from . import limits
from .catalog import ResolvedTrack, UnknownTrackError, default_catalog
from .errors import AssemblyError
from .params import RunParams
from .record import RaceType


@dataclass(frozen=True)
class Overrides:
    """Values given on the command line; they win over what the files say."""

    track: str | None = None
    racer: str | None = None
    model: str | None = None
    custom_track: bool = False
    race_type: str | None = None


@dataclass(frozen=True)
class Identity:
    track: ResolvedTrack
    direction: str | None
    racer: str
    race_type: RaceType
    model_name: str


#: Prefixes that name no model in particular: DeepRacer-for-Cloud's default, and the folders
#: the console and DeepRacer on AWS keep a model's artifacts in.
GENERIC_PREFIXES = {"rl-deepracer-sagemaker", "sagemaker-robomaker-artifacts", "sagemaker-artifacts"}


def choose_track(described: list[RunParams], overrides: Overrides) -> ResolvedTrack | None:
    """The evaluations' track: --track, else the WORLD_NAME their parameters share."""
    if overrides.track:
        return resolve(overrides.track, custom=overrides.custom_track, source="--track")
    resolved: dict[str, ResolvedTrack] = {}
    for params in described:
        world = params.text("WORLD_NAME")
        if world:
            track = resolve(world, custom=True, source=params.name)
            resolved.setdefault(track.track_id, track)
    if len(resolved) > 1:
        source = described[0].name if len(described) == 1 else "evaluation parameters"
        raise AssemblyError(source, "WORLD_NAME", f"evaluations on several tracks "
                            f"({', '.join(sorted(resolved))}); choose one", flag="--track")
    return next(iter(resolved.values()), None)


def names_track(params: RunParams, track: ResolvedTrack) -> bool:
    world = params.text("WORLD_NAME")
    if world is None:
        return True
    try:
        return resolve(world, custom=False, source=params.name).track_id == track.track_id
    except AssemblyError:
        return world == track.track_id


def identify(track: ResolvedTrack | None, evaluation: list[RunParams], training: list[RunParams],
             overrides: Overrides, where: str, default_model: str) -> Identity:
    """The run's identity; every fact the files do not say named in one refusal, with what the
    training's parameters say of the track."""
    described = evaluation + training
    racer = overrides.racer or first_text(described, "RACER_NAME", "DISPLAY_NAME", "CAR_NAME")
    race_type = _race_type(described, overrides, where)
    if track is None or not racer or race_type is None:
        raise _missing(track, racer, race_type, training, where)
    return Identity(
        track=track,
        direction=track.direction or _direction(evaluation),
        racer=racer,
        race_type=race_type,
        model_name=overrides.model or model_name(described, default_model),
    )


def _missing(track: ResolvedTrack | None, racer: str | None, race_type: RaceType | None,
             training: list[RunParams], where: str) -> AssemblyError:
    trained_on = training_track(first_text(training, "WORLD_NAME"))
    track_flag = "--track"
    if trained_on is not None:
        track_flag = f"--track {trained_on} if the evaluation ran there too"
    missing = [(field, flag) for field, flag, known in (
        ("WORLD_NAME", track_flag, track is not None),
        ("RACER_NAME", "--racer", bool(racer)),
        ("RACE_TYPE", "--race-type", race_type is not None),
    ) if not known]
    problem = "the run's files do not say"
    if track is None and trained_on is not None:
        problem = (f"the evaluation's files do not say its track; the training ran on {trained_on}"
                   if len(missing) == 1 else f"the run's files do not say (the training ran on {trained_on})")
    return AssemblyError(where, ", ".join(field for field, _ in missing), problem,
                         flag=", ".join(flag for _, flag in missing))


def resolve(name: str, *, custom: bool, source: str) -> ResolvedTrack:
    catalog = default_catalog()
    try:
        return catalog.resolve_custom(name) if custom else catalog.resolve(name)
    except UnknownTrackError as error:
        field = "" if source == "--track" else "WORLD_NAME"
        hint = "" if error.ambiguous or custom else "; pass --custom-track for a track of your own"
        raise AssemblyError(source, field, f"{error}{hint}") from None


def training_track(world: str | None) -> str | None:
    """The training's track as the catalog names it; a name it does not know, as written (when
    it could be a track's name at all)."""
    if world is None:
        return None
    try:
        return default_catalog().resolve(world).track_id
    except UnknownTrackError:
        return world if len(world) <= limits.MAX_NAME_CHARS and world.isprintable() else None


def first_text(params: list[RunParams], *keys: str) -> str | None:
    for key in keys:
        for p in params:
            if value := p.text(key):
                return value
    return None


def model_name(params: list[RunParams], folder: str) -> str:
    """MODEL_NAME, else the model's S3 prefix (DeepRacer-for-Cloud names its models by the
    prefix), else the folder's (or the archive's) name."""
    if name := first_text(params, "MODEL_NAME"):
        return name
    prefix = first_text(params, "MODEL_S3_PREFIX", "SAGEMAKER_SHARED_S3_PREFIX")
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
    text = overrides.race_type or first_text(params, "RACE_TYPE")
    if text is None:
        return RaceType.TIME_TRIAL if params else None
    try:
        return RaceType(text.strip().upper())
    except ValueError:
        source = "--race-type" if overrides.race_type else next(
            (p.name for p in params if p.text("RACE_TYPE")), where)
        choices = ", ".join(RaceType)
        raise AssemblyError(source, "" if overrides.race_type else "RACE_TYPE",
                            f"unknown race type {text[:40]!r} (one of {choices})") from None
