"""The official track list, with the aliases racers type and closest-match errors."""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Literal

Direction = Literal["cw", "ccw"]

_DIRECTION_SUFFIX = re.compile(r"^(?P<base>.+?)_(?P<dir>cw|ccw)$", re.IGNORECASE)
_CUSTOM_TRACK = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


@dataclass(frozen=True)
class Track:
    world_name: str
    display_name: str
    length_m: float
    width_m: float
    has_direction_variants: bool
    #: The shortest closed path the car's centre can drive without going off track, derived from
    #: the simulator's route files by scripts/derive_track_geometry.py; the official length
    #: (the centre line's) where the catalog holds no route.
    shortest_lap_m: float = 0.0

    def __post_init__(self) -> None:
        if not self.shortest_lap_m:
            object.__setattr__(self, "shortest_lap_m", self.length_m)


@dataclass(frozen=True)
class ResolvedTrack:
    track_id: str
    direction: Direction | None
    track: Track | None  # None for a custom track

    @property
    def display_name(self) -> str:
        return self.track.display_name if self.track else self.track_id


class UnknownTrackError(ValueError):
    """The name matches no track, or several: the message lists the closest."""

    def __init__(self, name: str, candidates: list[str], *, ambiguous: bool) -> None:
        self.name = name
        self.candidates = candidates
        self.ambiguous = ambiguous
        if ambiguous:
            message = f"track {name!r} is ambiguous: it could be {_listing(candidates)}"
        elif candidates:
            message = f"unknown track {name!r}; closest matches: {_listing(candidates)}"
        else:
            message = f"unknown track {name!r}"
        super().__init__(message)


def _listing(names: list[str]) -> str:
    return ", ".join(names)


def _key(text: str) -> str:
    return re.sub(r"[^a-z0-9]", "", text.casefold())


class TrackCatalog:
    def __init__(self, tracks: list[Track]) -> None:
        self.tracks = {t.world_name: t for t in tracks}
        self._by_key: dict[str, set[str]] = {}
        for track in tracks:
            for alias in self._aliases(track):
                self._by_key.setdefault(alias, set()).add(track.world_name)

    @staticmethod
    def _aliases(track: Track) -> set[str]:
        world = _key(track.world_name)
        aliases = {world, _key(track.display_name)}
        if world.endswith("track") and len(world) > len("track"):
            aliases.add(world.removesuffix("track"))
        return aliases

    def get(self, world_name: str) -> Track | None:
        return self.tracks.get(world_name)

    def resolve(self, name: str) -> ResolvedTrack:
        """Resolve a WORLD_NAME, an alias or a display name to a catalog track.

        A ``_cw``/``_ccw`` suffix sets the direction. Raises UnknownTrackError.
        """
        text = name.strip()
        direction: Direction | None = None
        match = _DIRECTION_SUFFIX.match(text)
        if match and self.lookup(match["base"]):
            text = match["base"]
            direction = "cw" if match["dir"].lower() == "cw" else "ccw"
        found = self.lookup(text)
        if len(found) == 1:
            world = next(iter(found))
            return ResolvedTrack(world, direction, self.tracks[world])
        if found:
            raise UnknownTrackError(name, sorted(found), ambiguous=True)
        raise UnknownTrackError(name, self.closest(text), ambiguous=False)

    def lookup(self, text: str) -> set[str]:
        if text in self.tracks:
            return {text}
        key = _key(text)
        if not key:
            return set()
        if key in self._by_key:
            return self._by_key[key]
        if len(key) >= 4:
            prefixed = {w for alias, names in self._by_key.items() if alias.startswith(key)
                        for w in names}
            return prefixed
        return set()

    def closest(self, text: str, count: int = 5) -> list[str]:
        import difflib  # here: only a refusal needs it, not the requests the functions serve

        key = _key(text)
        close = difflib.get_close_matches(key, self._by_key, n=count * 2, cutoff=0.5)
        names: list[str] = []
        for alias in close:
            for world in sorted(self._by_key[alias]):
                label = f"{world} ({self.tracks[world].display_name})"
                if label not in names:
                    names.append(label)
        return names[:count]

    def resolve_custom(self, name: str) -> ResolvedTrack:
        """Take ``name`` exactly as a custom track; it must not be an official track's name."""
        text = name.strip()
        if not _CUSTOM_TRACK.match(text):
            raise UnknownTrackError(name, [], ambiguous=False)
        try:
            return self.resolve(text)
        except UnknownTrackError as error:
            if error.ambiguous:
                raise
        return ResolvedTrack(text, None, None)

    def is_official(self, track_id: str) -> bool:
        return track_id in self.tracks


@cache
def default_catalog() -> TrackCatalog:
    data = resources.files("drboard_assembler").joinpath("data")
    shortest = {row["world_name"]: float(row["shortest_lap_m"]) for row in
                csv.DictReader(data.joinpath("track_geometry.csv").read_text("utf-8").splitlines())}
    tracks = [
        Track(
            world_name=row["world_name"],
            display_name=row["display_name"],
            length_m=float(row["length_m"]),
            width_m=float(row["width_m"]),
            has_direction_variants=row["cw_ccw_variants"].strip().lower() == "yes",
            shortest_lap_m=shortest.get(row["world_name"], 0.0),
        )
        for row in csv.DictReader(data.joinpath("tracks.csv").read_text("utf-8").splitlines())
    ]
    return TrackCatalog(tracks)
