"""Seasons: organisers make a season out of boards (its rounds), set its points table, how many
rounds count and its final; everyone reads its standings. How the points add up is in
:mod:`drboard_functions.season_scoring`.

**How standings stay cheap to read.** A season's standings are not recomputed from every round's
every entry at each view. The season keeps each round's results (its finishes in rank order, up
to ``MAX_ROUND_RACERS``) as of a version of the round's board, and every change to a board's
standings — a push, a removed entry, a ban or an unban, an import — bumps that version in the
same write. A view reads the season, the results it keeps and its rounds' boards (for their
versions): ``1 + 2 × rounds`` items on DynamoDB whatever the fields' sizes; only a round whose
board moved since is read again (its entries, in rank order) and kept anew. The results are
kept on read, not maintained on write, so no push or moderation path has to know about seasons,
and a change nobody looks at costs nothing. A closed season reads only what it kept when it
closed: past seasons stay as they ended, whatever later happens to their boards.

**The final.** A season may name a later board its final, whose only entrants are the top K of
the season's standings over its other rounds (or of one of its rounds). A push to a board
checks it with :func:`check_entrant`: one read of the board's season links, and for a final the
season's standings, as above.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from ..cursors import decode_page_cursor, page_cursor
from ..display import ordinal, points_text
from ..errors import (
    BoardNotFound,
    InvalidQuery,
    NotQualified,
    SeasonExists,
    SeasonLocked,
    SeasonNotFound,
)
from ..models.domain import MAX_PAGE, BoardStatus
from ..models.seasons import (
    MAX_ROUND_RACERS,
    MAX_ROUNDS,
    FinalSpec,
    FinalView,
    RoundResults,
    RoundSpec,
    RoundView,
    Season,
    SeasonChanges,
    SeasonFinal,
    SeasonLink,
    SeasonList,
    SeasonRound,
    SeasonSpec,
    SeasonStandings,
    SeasonStatus,
    SeasonSummary,
    SeasonView,
)
from ..season_scoring import (
    TIE_BREAKS,
    Ranked,
    finishes,
    round_qualifiers,
    season_qualifiers,
    standings,
)
from ..stores.base import SeasonConflict, StoredBoard
from .boards import BoardKeeper, racer_key
from .paging import DEFAULT_PAGE, check_limit

#: How many of the qualifiers a refusal names.
NAMED_QUALIFIERS = 10


class Seasons:
    def __init__(self, keeper: BoardKeeper) -> None:
        self.keeper = keeper
        self.store = keeper.store
        self.clock = keeper.clock

    # ---- organisers -----------------------------------------------------------------------

    def create_season(self, spec: SeasonSpec) -> SeasonStandings:
        season = Season(season_id=spec.season_id, title=spec.title, description=spec.description,
                        points=spec.points, best_of=spec.best_of, created_at=self.clock(),
                        version=1)
        try:
            saved = self.store.save_season(season, {})
        except SeasonConflict:
            raise SeasonExists(f"there is already a season {spec.season_id!r}") from None
        return self._standings(saved)

    def update_season(self, season_id: str, changes: SeasonChanges) -> SeasonStandings:
        """Change the title, description, points table or best-of: only the fields given."""
        season = self._open(season_id)
        given = changes.model_fields_set
        for name in ("title", "points"):
            if name in given and getattr(changes, name) is None:
                raise InvalidQuery(f"{name} cannot be cleared")
        updates = {name: getattr(changes, name) for name in given}
        if "description" in updates and updates["description"] is None:
            updates["description"] = ""
        return self._save(season, season.model_copy(update=updates))

    def add_round(self, season_id: str, board_id: str, spec: RoundSpec | None = None) -> SeasonStandings:
        """Make the board a round of the season, or change a round's weight and whether it
        always counts. Rounds are numbered in the order their boards open."""
        spec = spec or RoundSpec()
        season = self._open(season_id)
        board = self.keeper.require(board_id).board
        existing = season.round(board_id)
        if existing is None and len(season.rounds) >= MAX_ROUNDS:
            raise InvalidQuery(f"a season has at most {MAX_ROUNDS} rounds")
        added = SeasonRound(board_id=board_id, weight=spec.weight, always_counts=spec.always_counts,
                            added_at=existing.added_at if existing else self.clock(),
                            starts_at=board.opens_at or board.created_at)
        others = [r for r in season.rounds if r.board_id != board_id]
        rounds = sorted([*others, added], key=SeasonRound.order)
        return self._save(season, season.model_copy(update={"rounds": rounds}))

    def remove_round(self, season_id: str, board_id: str) -> SeasonStandings:
        season = self._open(season_id)
        if season.round(board_id) is None:
            raise BoardNotFound(f"{board_id!r} is not a round of {season_id!r}")
        if season.final and season.final.from_round == board_id:
            raise SeasonLocked(f"the final of {season_id!r} takes the top of {board_id!r}: "
                               "change or clear the final first")
        rounds = [r for r in season.rounds if r.board_id != board_id]
        return self._save(season, season.model_copy(update={"rounds": rounds}))

    def set_final(self, season_id: str, spec: FinalSpec) -> SeasonStandings:
        """Make a named board the season's final: only the season's top ``spec.top`` (or the
        top of the round ``spec.from_round``) may push to it."""
        season = self._open(season_id)
        self.keeper.named(spec.board_id)
        if spec.from_round is not None:
            if season.round(spec.from_round) is None:
                raise InvalidQuery(f"{spec.from_round!r} is not a round of {season_id!r}",
                                   detail=[{"loc": "from_round", "msg": "not a round of the season",
                                            "type": "value_error"}])
            if spec.from_round == spec.board_id:
                raise InvalidQuery("a final cannot take its entrants from itself")
        final = SeasonFinal(board_id=spec.board_id, top=spec.top, from_round=spec.from_round)
        return self._save(season, season.model_copy(update={"final": final}))

    def clear_final(self, season_id: str) -> SeasonStandings:
        """The season has no final: its board takes anyone's pushes again."""
        season = self._open(season_id)
        return self._save(season, season.model_copy(update={"final": None}))

    def close_season(self, season_id: str) -> SeasonStandings:
        """Close the season: its standings stay as they are now, whatever later happens to
        its boards (reopen it to let them move it again)."""
        season = self._season(season_id)
        if season.closed_at is not None:
            return self._standings(season)
        self._results(season)  # every round's results, fresh, kept as the season ends
        return self._save(season, season.model_copy(update={"closed_at": self.clock()}))

    def reopen_season(self, season_id: str) -> SeasonStandings:
        season = self._season(season_id)
        if season.closed_at is None:
            return self._standings(season)
        return self._save(season, season.model_copy(update={"closed_at": None}))

    # ---- reads ----------------------------------------------------------------------------

    def seasons_page(self, limit: int = DEFAULT_PAGE, cursor: str | None = None) -> SeasonList:
        """The seasons by id, current and past, ``limit`` at a time."""
        check_limit(limit)
        page = self.store.seasons_page(decode_page_cursor("seasons", cursor), limit)
        return SeasonList(seasons=[_summary(s) for s in page.seasons],
                          next_cursor=page_cursor("seasons", page.after))

    def seasons(self) -> list[SeasonSummary]:
        """Every season, by id."""
        listed: list[SeasonSummary] = []
        cursor: str | None = None
        while True:
            page = self.seasons_page(MAX_PAGE, cursor)
            listed += page.seasons
            if (cursor := page.next_cursor) is None:
                return listed

    def season(self, season_id: str, limit: int = DEFAULT_PAGE,
               cursor: str | None = None) -> SeasonStandings:
        """The season and its standings, ``limit`` racers from ``cursor``."""
        check_limit(limit)
        return self._standings(self._season(season_id), limit, cursor)

    def board_seasons(self, board_id: str) -> list[SeasonLink]:
        """The seasons the board is a round or the final of."""
        return self.store.season_links(board_id)

    def check_entrant(self, board_id: str, racer: str, finals: Sequence[SeasonLink]) -> None:
        """Refuse a push to a season's final by a racer who did not qualify for it (a board
        that is the final of several seasons takes each one's qualifiers); ``finals``: the
        board's links to the seasons it is the final of."""
        key = racer_key(racer)
        refusals: list[str] = []
        for link in finals:
            season = self.store.get_season(link.season_id)
            if season is None or season.final is None or season.final.board_id != board_id:
                continue
            results = self._results(season)
            qualified = self._qualifiers(season, results)
            if any(k == key for k, _ in qualified):
                return
            refusals.append(_refusal(season, [name for _, name in qualified])
                            + " " + self._standing_of(season, results, key, racer))
        if refusals:
            raise NotQualified(f"{board_id!r} is a final: {racer!r} did not qualify for it. "
                               + " ".join(refusals))

    # ---- the standings --------------------------------------------------------------------

    def _standings(self, season: Season, limit: int = DEFAULT_PAGE,
                   cursor: str | None = None) -> SeasonStandings:
        start = _position(cursor)
        boards = self.store.boards_by_id(sorted(season.linked_boards()))
        results = self._results(season, boards)
        table = standings(season, results)
        qualified = {key for key, _ in self._qualifiers(season, results, table)}
        shown = [ranked.standing.model_copy(update={"qualified_for_final": ranked.racer_key in qualified})
                 for ranked in table[start:start + limit]]
        more = start + limit < len(table)
        return SeasonStandings(season=self._view(season, boards, results, table),
                               standings=shown,
                               next_cursor=page_cursor("standings", str(start + limit)) if more else None)

    def _results(self, season: Season,
                 boards: Mapping[str, StoredBoard] | None = None) -> dict[str, RoundResults | None]:
        """Each round's results: as kept, unless its board changed since (then read again and
        kept), or is gone (None). A closed season has only what it kept."""
        kept = self.store.round_results(season.season_id)
        if season.closed_at is not None:
            return {r.board_id: kept.get(r.board_id) for r in season.rounds}
        if boards is None:
            boards = self.store.boards_by_id([r.board_id for r in season.rounds])
        results: dict[str, RoundResults | None] = {}
        for season_round in season.rounds:
            board_id = season_round.board_id
            stored = boards.get(board_id)
            if stored is None or stored.board.deleted_at is not None:
                results[board_id] = None
            elif (known := kept.get(board_id)) is not None and known.board_version == stored.version:
                results[board_id] = known
            else:
                results[board_id] = self._read_round(season.season_id, board_id)
        return results

    def _read_round(self, season_id: str, board_id: str) -> RoundResults | None:
        """The round's finishes from its board's entries, kept for the season. The board's
        version is read before its entries: results kept under an older version than they
        hold are only read again, never kept past a change."""
        stored, entries = self.store.front_page(board_id, MAX_PAGE)
        if stored is None or stored.board.deleted_at is not None:
            return None
        page = entries
        while len(page) == MAX_PAGE and len(entries) < MAX_ROUND_RACERS:
            page = self.store.top(board_id, min(MAX_PAGE, MAX_ROUND_RACERS - len(entries)),
                                  entries[-1].rank_key)
            entries = entries + page
        results = RoundResults(board_id=board_id, board_version=stored.version,
                               field=stored.participants, finishes=finishes(entries))
        self.store.keep_round_results(season_id, results)
        return results

    def _qualifiers(self, season: Season, results: Mapping[str, RoundResults | None],
                    table: Sequence[Ranked] | None = None) -> list[tuple[str, str]]:
        """The final's entrants, best first, as (racer key, racer)."""
        final = season.final
        if final is None:
            return []
        if final.from_round is not None:
            return [(f.racer_key, f.racer)
                    for f in round_qualifiers(results.get(final.from_round), final.top)]
        if table is None or season.round(final.board_id) is not None:
            table = standings(season, results, without=final.board_id)
        return [(r.racer_key, r.standing.racer) for r in season_qualifiers(table, final.top)]

    def _standing_of(self, season: Season, results: Mapping[str, RoundResults | None],
                     key: str, racer: str) -> str:
        """Where a racer who did not qualify stands, where the final's entrants come from."""
        final = season.final
        assert final is not None
        if final.from_round is not None:
            result = results.get(final.from_round)
            finish = next((f for f in result.finishes if f.racer_key == key), None) if result else None
            if finish is None:
                return f"{racer} did not race it."
            return (f"{racer} finished {ordinal(finish.rank)} there." if finish.qualified
                    else f"{racer} raced it without a qualifying run.")
        table = standings(season, results, without=final.board_id)
        mine = next((r.standing for r in table if r.racer_key == key), None)
        if mine is None or not mine.points:
            return f"{racer} has no points in it."
        return f"{racer} is {ordinal(mine.rank)} with {points_text(mine.points)} points."

    def _view(self, season: Season, boards: Mapping[str, StoredBoard],
              results: Mapping[str, RoundResults | None], table: Sequence[Ranked]) -> SeasonView:
        now = self.clock()
        rounds = []
        for number, season_round in enumerate(season.rounds, start=1):
            stored = boards.get(season_round.board_id)
            live = stored is not None and stored.board.deleted_at is None
            status: BoardStatus | str = stored.board.status(now) if stored and live else "MISSING"
            kept = results.get(season_round.board_id)
            rounds.append(RoundView.model_validate({
                "number": number, "board_id": season_round.board_id,
                "title": stored.board.title if stored else season_round.board_id,
                "weight": season_round.weight, "always_counts": season_round.always_counts,
                "status": status, "participants": kept.field if kept else 0}))
        final = None
        if season.final is not None:
            stored = boards.get(season.final.board_id)
            final = FinalView(board_id=season.final.board_id,
                              title=stored.board.title if stored else season.final.board_id,
                              top=season.final.top, from_round=season.final.from_round,
                              qualifiers=[name for _, name in self._qualifiers(season, results, table)])
        return SeasonView(season_id=season.season_id, title=season.title,
                          description=season.description, status=_status(season),
                          points=season.points, best_of=season.best_of, rounds=rounds, final=final,
                          tie_breaks=TIE_BREAKS, created_at=season.created_at,
                          closed_at=season.closed_at, version=season.version)

    # ---- keeping seasons ------------------------------------------------------------------

    def _season(self, season_id: str) -> Season:
        season = self.store.get_season(season_id)
        if season is None:
            raise SeasonNotFound(f"no season {season_id!r}")
        return season

    def _open(self, season_id: str) -> Season:
        season = self._season(season_id)
        if season.closed_at is not None:
            raise SeasonLocked(f"the season {season_id!r} is closed: reopen it to change it "
                               f"(`drboard season reopen {season_id}`)")
        return season

    def _save(self, old: Season, new: Season) -> SeasonStandings:
        """Write the change, with the boards whose links to the season it changes."""
        new = Season.model_validate(new.model_dump() | {"version": old.version + 1})
        if new.model_copy(update={"version": old.version}) == old:
            return self._standings(old)  # nothing changes: nothing is written
        before, after = _links(old), _links(new)
        changed: dict[str, SeasonLink | None] = {
            board_id: after.get(board_id) for board_id in before.keys() | after.keys()
            if before.get(board_id) != after.get(board_id)}
        dropped = sorted({r.board_id for r in old.rounds} - {r.board_id for r in new.rounds})
        try:
            saved = self.store.save_season(new, changed, forget=dropped)
        except SeasonConflict:
            raise SeasonLocked(f"the season {old.season_id!r} was changed meanwhile: "
                               "look at it again and retry") from None
        return self._standings(saved)


def check_entrant(keeper: BoardKeeper, board_id: str, racer: str,
                  finals: Sequence[SeasonLink]) -> None:
    """The push path's check of a season's final (``finals``: the board's links to the seasons
    it is the final of): a racer who did not qualify is refused (``NotQualified``)."""
    Seasons(keeper).check_entrant(board_id, racer, finals)


def _links(season: Season) -> dict[str, SeasonLink]:
    final = season.final.board_id if season.final else None
    return {board_id: SeasonLink(season_id=season.season_id, title=season.title,
                                 final=board_id == final)
            for board_id in season.linked_boards()}


def _status(season: Season) -> SeasonStatus:
    return "OPEN" if season.closed_at is None else "CLOSED"


def _summary(season: Season) -> SeasonSummary:
    return SeasonSummary.model_validate({
        "season_id": season.season_id, "title": season.title, "status": _status(season),
        "rounds": len(season.rounds), "final_board_id": season.final.board_id if season.final else None,
        "created_at": season.created_at, "closed_at": season.closed_at})


def _position(cursor: str | None) -> int:
    after = decode_page_cursor("standings", cursor)
    if after is None:
        return 0
    if not after.isdecimal():
        raise InvalidQuery("the cursor is not one this board gave out")
    return int(after)


def _refusal(season: Season, qualified: list[str]) -> str:
    assert season.final is not None
    source = (f"the top {season.final.top} of its round {season.final.from_round!r}"
              if season.final.from_round else
              f"the top {season.final.top} of the season {season.title!r}")
    named = ", ".join(qualified[:NAMED_QUALIFIERS])
    if len(qualified) > NAMED_QUALIFIERS:
        named += f" and {len(qualified) - NAMED_QUALIFIERS} more"
    return (f"Its entrants are {source}: {named}." if qualified
            else f"Its entrants are {source}, and no racer has qualified yet.")
