#!/usr/bin/env python3
"""Derive each official track's lap lengths from the simulator's route files.

    python scripts/derive_track_geometry.py /path/to/deepracer-simapp

reads ``bundle/routes/<WORLD_NAME>.npy`` (or its ``_ccw`` variant) of a deepracer-simapp checkout
for every track of ``assembler/drboard_assembler/data/tracks.csv`` and writes
``assembler/drboard_assembler/data/track_geometry.csv``: the centre line's length and the
shortest closed path the car's centre can drive while the simulator still counts the car on the
track. Only these figures ship with drboard, not the route files.

A route file is an (N, 6) float64 array: per waypoint the centre line's x, y, the inner border's
x, y and the outer border's x, y, in metres. The simulator calls a car off track only when none of
its four wheels is on the road (deepracer-simapp, ``OffTrackResetRule``), so the car's centre may
leave the road by up to the distance from the centre to a wheel: 0.115 m on the DeepRacer model
(wheels at x = ±0.082 m, y = ±0.081 m of the chassis). ``MARGIN_M`` rounds it up.

The shortest path is found on the cross-sections at the waypoints: the path takes one point on each
(from the inner border widened by the margin to the outer one) and joins them with straight lines;
the sum of the segments' lengths is convex in those points, and moving each point in turn to the
best place between its neighbours converges on the shortest closed path.
"""

from __future__ import annotations

import argparse
import ast
import csv
import math
import struct
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TRACKS = ROOT / "assembler" / "drboard_assembler" / "data" / "tracks.csv"
OUTPUT = ROOT / "assembler" / "drboard_assembler" / "data" / "track_geometry.csv"
MARGIN_M = 0.12
TOLERANCE_M = 1e-7
MAX_SWEEPS = 200_000

Point = tuple[float, float]


def read_route(path: Path) -> list[tuple[float, ...]]:
    """The rows of a little-endian float64 .npy array of shape (N, 6)."""
    data = path.read_bytes()
    if data[:6] != b"\x93NUMPY":
        raise ValueError(f"{path}: not a .npy file")
    major = data[6]
    if major == 1:
        (header_length,), start = struct.unpack("<H", data[8:10]), 10
    else:
        (header_length,), start = struct.unpack("<I", data[8:12]), 12
    header = ast.literal_eval(data[start:start + header_length].decode("latin-1"))
    if header["descr"] != "<f8" or header["fortran_order"]:
        raise ValueError(f"{path}: expected a C-ordered little-endian float64 array")
    rows, columns = header["shape"]
    values = struct.unpack(f"<{rows * columns}d", data[start + header_length:][: rows * columns * 8])
    return [values[row * columns:(row + 1) * columns] for row in range(rows)]


def open_loop(rows: list[tuple[float, ...]]) -> list[tuple[float, ...]]:
    """The waypoints without the closing copy of the first one, when the file repeats it."""
    if len(rows) > 2 and math.dist(rows[0][:2], rows[-1][:2]) < 1e-3:
        return rows[:-1]
    return rows


def centre_line_length(rows: list[tuple[float, ...]]) -> float:
    return sum(math.dist(rows[i][:2], rows[(i + 1) % len(rows)][:2]) for i in range(len(rows)))


def cross_sections(rows: list[tuple[float, ...]], margin: float) -> list[tuple[Point, Point]]:
    """Per waypoint, the segment the car's centre may be on: the road's width plus the margin
    on either side."""
    sections = []
    for cx, cy, ix, iy, ox, oy in rows:
        sections.append((_beyond((cx, cy), (ix, iy), margin), _beyond((cx, cy), (ox, oy), margin)))
    return sections


def _beyond(centre: Point, border: Point, margin: float) -> Point:
    length = math.dist(centre, border)
    if length == 0:
        return border
    scale = (length + margin) / length
    return centre[0] + (border[0] - centre[0]) * scale, centre[1] + (border[1] - centre[1]) * scale


def shortest_closed_path(sections: list[tuple[Point, Point]]) -> float:
    """The length of the shortest closed path through one point of every cross-section."""
    positions = [0.5] * len(sections)
    for _ in range(MAX_SWEEPS):
        moved = 0.0
        for index, (start, end) in enumerate(sections):
            before = _at(sections, positions, index - 1)
            after = _at(sections, positions, (index + 1) % len(sections))
            best = _best_position(start, end, before, after)
            moved = max(moved, abs(best - positions[index]) * math.dist(start, end))
            positions[index] = best
        if moved < TOLERANCE_M:
            break
    else:
        raise RuntimeError("the path did not settle")
    points = [_at(sections, positions, index) for index in range(len(sections))]
    return sum(math.dist(points[i], points[(i + 1) % len(points)]) for i in range(len(points)))


def _at(sections: list[tuple[Point, Point]], positions: list[float], index: int) -> Point:
    (sx, sy), (ex, ey) = sections[index]
    t = positions[index]
    return sx + (ex - sx) * t, sy + (ey - sy) * t


def _best_position(start: Point, end: Point, before: Point, after: Point) -> float:
    """Where on the segment start..end the sum of the distances to ``before`` and ``after`` is
    least: where the straight line between them (or between ``before`` and ``after``'s mirror
    image, when both lie on one side) crosses the segment, clamped to it."""
    dx, dy = end[0] - start[0], end[1] - start[1]
    length_sq = dx * dx + dy * dy
    if length_sq == 0:
        return 0.0

    def side(point: Point) -> float:
        return dx * (point[1] - start[1]) - dy * (point[0] - start[0])

    target = after
    if side(before) * side(after) > 0:  # mirror ``after`` in the segment's line
        t = ((after[0] - start[0]) * dx + (after[1] - start[1]) * dy) / length_sq
        foot = start[0] + dx * t, start[1] + dy * t
        target = 2 * foot[0] - after[0], 2 * foot[1] - after[1]
    denominator = side(before) - side(target)
    if denominator == 0:  # both on the line: any point between them is as good
        t_before = ((before[0] - start[0]) * dx + (before[1] - start[1]) * dy) / length_sq
        return min(1.0, max(0.0, t_before))
    # the crossing of before..target with the line, as a fraction along start..end
    weight = side(before) / denominator
    cross = before[0] + (target[0] - before[0]) * weight, before[1] + (target[1] - before[1]) * weight
    t = ((cross[0] - start[0]) * dx + (cross[1] - start[1]) * dy) / length_sq
    return min(1.0, max(0.0, t))


def route_files(routes: Path, world: str) -> list[Path]:
    """The track's route files: its own and its clockwise and counter-clockwise variants', which
    are sampled differently (the shortest path of each counts: the floor is the least)."""
    return [path for name in (world, f"{world}_ccw", f"{world}_cw")
            if (path := routes / f"{name}.npy").is_file()]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("simapp", type=Path, help="a checkout of deepracer-simapp")
    parser.add_argument("--output", type=Path, default=OUTPUT)
    args = parser.parse_args()
    routes = args.simapp / "bundle" / "routes"
    with TRACKS.open(encoding="utf-8") as handle:
        worlds = [row["world_name"] for row in csv.DictReader(handle)]
    rows = []
    for world in worlds:
        paths = route_files(routes, world)
        if not paths:
            print(f"{world}: no route file", file=sys.stderr)
            continue
        routes_of_track = [open_loop(read_route(path)) for path in paths]
        centre = centre_line_length(routes_of_track[0])
        shortest = min(shortest_closed_path(cross_sections(waypoints, MARGIN_M))
                       for waypoints in routes_of_track)
        rows.append({"world_name": world, "route_files": " ".join(p.name for p in paths),
                     "centre_line_m": f"{centre:.2f}", "shortest_lap_m": f"{shortest:.2f}"})
        print(f"{world:<28} centre {centre:7.2f} m  shortest {shortest:7.2f} m  "
              f"({shortest / centre:.0%})", file=sys.stderr)
    with args.output.open("w", encoding="utf-8", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {args.output} ({len(rows)} tracks, margin {MARGIN_M} m)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
