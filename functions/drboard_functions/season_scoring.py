"""How a season's rounds add up: points for each finish, the best N rounds of each racer, the
rounds' weights, the tie-breaks, and who qualifies for the final. Pure: the service hands it
each round's finishes.

- A round's finishes are its board's entries in rank order, ranks shared as the board shares
  them (1 + the racers strictly better).
- Place points go only to a racer whose run qualified on the round (see ``PointsTable``); the
  points for taking part go to every racer with an entry. The round's weight multiplies both.
- With best-of N, a racer's N best rounds count (the earlier round first among equal points);
  a round that always counts (a final) is counted whatever best-of says, and takes one of the N.
- Ties on points are broken, in order, by more round wins, then the better best finish, then
  whoever set that best finish first (the earlier result). Racers still level share the rank.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import NamedTuple

from .models.domain import Entry
from .models.seasons import (
    Finish,
    PointsTable,
    RoundResults,
    RoundScore,
    Season,
    SeasonRound,
    Standing,
)

TIE_BREAKS = ("Ties on points go to more round wins, then the better best finish, then whoever "
              "set that best finish first.")
_LATEST = datetime.max


def finishes(entries: Iterable[Entry]) -> list[Finish]:
    """The board's entries (in rank order) as finishes, equal scores sharing a rank."""
    placed: list[Finish] = []
    previous_key: str | None = None
    for position, entry in enumerate(entries, start=1):
        rank = placed[-1].rank if placed and entry.score_key == previous_key else position
        placed.append(Finish(racer_key=entry.racer_key, racer=entry.racer, rank=rank,
                             qualified=entry.score.qualified, achieved_at=entry.achieved_at))
        previous_key = entry.score_key
    return placed


def place_points(table: PointsTable, rank: int, field_size: int) -> int:
    """The points of a qualified finish at ``rank`` in a field of ``field_size`` racers."""
    if table.scheme == "percentile":
        field_size = max(field_size, rank)
        share = table.percentile_max * (field_size - rank + 1) / field_size
        return max(1, math.floor(share + 0.5))
    return table.positions[rank - 1] if rank <= len(table.positions) else 0


def finish_points(table: PointsTable, finish: Finish, field_size: int, weight: float) -> float:
    place = place_points(table, finish.rank, field_size) if finish.qualified else 0
    return round((place + table.participation) * weight, 2)


@dataclass
class _Racer:
    racer_key: str
    racer: str = ""
    # by round position: (finish, points) of the rounds raced
    raced: dict[int, tuple[Finish, float]] = field(default_factory=dict)
    counted: set[int] = field(default_factory=set)

    @property
    def points(self) -> float:
        return round(sum(self.raced[i][1] for i in self.counted), 2)

    @property
    def wins(self) -> int:
        return sum(1 for f, _ in self.raced.values() if f.qualified and f.rank == 1)

    @property
    def best_finish(self) -> int | None:
        ranks = [f.rank for f, _ in self.raced.values() if f.qualified]
        return min(ranks) if ranks else None

    @property
    def best_finish_at(self) -> datetime:
        """When the racer first set their best finish (or, with none, first took part)."""
        best = self.best_finish
        moments = [f.achieved_at for f, _ in self.raced.values()
                   if best is None or (f.qualified and f.rank == best)]
        return min(moments) if moments else _LATEST

    def order_key(self) -> tuple[float, int, float, datetime]:
        best = self.best_finish
        return (-self.points, -self.wins, math.inf if best is None else best,
                self.best_finish_at.replace(tzinfo=None))


def _count_best(racer: _Racer, rounds: Sequence[SeasonRound], best_of: int | None) -> None:
    raced = sorted(racer.raced)
    if best_of is None:
        racer.counted = set(raced)
        return
    always = {i for i in raced if rounds[i].always_counts}
    others = sorted((i for i in raced if i not in always), key=lambda i: (-racer.raced[i][1], i))
    racer.counted = always | set(others[:max(0, best_of - len(always))])


class Ranked(NamedTuple):
    """A racer's standing, and their racer key (how rounds and finals know them)."""

    racer_key: str
    standing: Standing


def standings(season: Season, results: Mapping[str, RoundResults | None],
              without: str | None = None) -> list[Ranked]:
    """The season's standings from each round's results (None: the round has none, e.g. its
    board was deleted), best first. ``without`` leaves one round out (a final qualifies its
    entrants on the other rounds)."""
    rounds = [r for r in season.rounds if r.board_id != without]
    racers: dict[str, _Racer] = {}
    for position, season_round in enumerate(rounds):
        result = results.get(season_round.board_id)
        if result is None:
            continue
        for finish in result.finishes:
            racer = racers.setdefault(finish.racer_key, _Racer(finish.racer_key))
            racer.racer = finish.racer  # the latest round's spelling
            racer.raced[position] = (finish, finish_points(season.points, finish, result.field,
                                                           season_round.weight))
    for racer in racers.values():
        _count_best(racer, rounds, season.best_of)
    ordered = sorted(racers.values(), key=lambda r: (r.order_key(), r.racer_key))
    keys = [r.order_key() for r in ordered]
    table: list[Ranked] = []
    for index, racer in enumerate(ordered):
        rank = index + 1 if index == 0 or keys[index] != keys[index - 1] else table[-1].standing.rank
        table.append(Ranked(racer.racer_key, Standing(
            rank=rank, racer=racer.racer, points=racer.points, wins=racer.wins,
            best_finish=racer.best_finish, rounds_raced=len(racer.raced),
            qualified_for_final=False, rounds=[_round_score(racer, i, r) for i, r in enumerate(rounds)],
        )))
    return table


def _round_score(racer: _Racer, position: int, season_round: SeasonRound) -> RoundScore:
    raced = racer.raced.get(position)
    if raced is None:
        return RoundScore(board_id=season_round.board_id, rank=None, qualified=False, points=0,
                          counted=False)
    finish, points = raced
    return RoundScore(board_id=season_round.board_id, rank=finish.rank, qualified=finish.qualified,
                      points=points, counted=position in racer.counted)


def season_qualifiers(table: Sequence[Ranked], top: int) -> list[Ranked]:
    """The racers the season's standings send to the final: the first ``top`` (racers tied at
    the cut all go) who scored points."""
    return [r for r in table if r.standing.rank <= top and r.standing.points > 0]


def round_qualifiers(result: RoundResults | None, top: int) -> list[Finish]:
    """The finishers a round sends to the final: its first ``top`` whose run qualified (racers
    tied at the cut all go)."""
    if result is None:
        return []
    return [f for f in result.finishes if f.qualified and f.rank <= top]
