"""The leaderboard's use cases, one room per concern, behind one façade.

The service never touches a database: it speaks to a BoardStore. It takes validated Records and
returns the view models the API serialises and the CLI prints. Each concern has its own module:
``boards`` (which board a run belongs on, the checks a board makes, the audit trail),
``pushing`` (a push and its trust rules), ``reading`` (boards and their standings),
``racers`` (a racer's pages, designs compared),
``managing`` (organisers' named boards), ``moderating`` (entries off a board, bans, the audit
trail's reading), ``transfer`` (export, import and a board's recheck), ``aliases`` (the
organisers' hand on racers' aliases), ``results`` (laps to analyse), ``webhooks`` (the chat's
announcements), ``seasons`` (boards added up into a season's standings, and its final) and
``sharing`` (result cards); ``copies`` holds the rules of copied runs.
:class:`LeaderboardService` only hands each call to the room that answers it.

A room's module loads, and the room is built, when the service first hands it a call: the pull
function never imports the pushing, transfer or webhooks rooms (nor what they import), and the
push function no organiser's room. The names this package exports load their module likewise.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cached_property
from importlib import import_module
from typing import TYPE_CHECKING, Any, Concatenate, ParamSpec, TypeVar

from ..board_ids import CUSTOM_PREFIX, board_for_track, default_board_id, is_default_board_id
from .boards import BoardKeeper, Clock, StandingsKeeper, racer_key, utc_now

if TYPE_CHECKING:
    from ..models.notices import EntryChange
    from ..stores.base import BoardStore, RecordArchive
    from ..stores.pages import PageShelf
    from .aliases import Aliases
    from .copies import evaluation_fingerprints
    from .managing import Managing
    from .moderating import Moderating
    from .paging import DEFAULT_PAGE, DEFAULT_TOP, MAX_COMPARED, MAX_TOP
    from .pushing import Pushing, check_record_size, scored_write
    from .racers import Racers
    from .reading import Reading
    from .results import LAPS_PAGE, Results
    from .seasons import Seasons
    from .sharing import Sharing
    from .transfer import Transfer
    from .webhooks import Webhooks

P = ParamSpec("P")
R = TypeVar("R")

__all__ = [
    "CUSTOM_PREFIX", "DEFAULT_PAGE", "DEFAULT_TOP", "LAPS_PAGE", "MAX_COMPARED", "MAX_TOP", "Clock",
    "LeaderboardService", "StandingsKeeper", "board_for_track", "check_record_size", "default_board_id",
    "evaluation_fingerprints", "is_default_board_id", "racer_key", "scored_write", "utc_now",
]

#: The module each name exported from a room's module comes from (loaded on first use).
_HOMES = {"DEFAULT_PAGE": "paging", "DEFAULT_TOP": "paging", "MAX_COMPARED": "paging",
          "MAX_TOP": "paging", "LAPS_PAGE": "results", "check_record_size": "pushing",
          "scored_write": "pushing", "evaluation_fingerprints": "copies"}


def __getattr__(name: str) -> Any:
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(import_module(f"{__name__}.{home}"), name)


class _Unloaded:
    """A room's class whose module is not loaded yet. ``Pushing.push`` stands for the method a
    façade method hands its calls to (by name, see :func:`_handed_to`); ``Pushing(keeper)``
    loads the module and builds the room."""

    def __init__(self, module: str, name: str) -> None:
        self.module = module
        self.__name__ = name
        self.__doc__ = None  # a method's own, once its module is loaded

    def __getattr__(self, method: str) -> _Unloaded:
        return _Unloaded(self.module, method)

    def __call__(self, *args: Any) -> Any:
        return getattr(import_module(f"{__name__}.{self.module}"), self.__name__)(*args)


if not TYPE_CHECKING:  # each room's class stands for its module until the service first uses the room
    Aliases = _Unloaded("aliases", "Aliases")
    Managing = _Unloaded("managing", "Managing")
    Moderating = _Unloaded("moderating", "Moderating")
    Pushing = _Unloaded("pushing", "Pushing")
    Racers = _Unloaded("racers", "Racers")
    Reading = _Unloaded("reading", "Reading")
    Results = _Unloaded("results", "Results")
    Seasons = _Unloaded("seasons", "Seasons")
    Sharing = _Unloaded("sharing", "Sharing")
    Transfer = _Unloaded("transfer", "Transfer")
    Webhooks = _Unloaded("webhooks", "Webhooks")


def _handed_to(room: str, method: Callable[Concatenate[Any, P], R]) -> Callable[Concatenate[Any, P], R]:
    """A façade method that hands the call to the same method of one of the service's rooms."""
    name = method.__name__

    def hand_over(self: Any, /, *args: P.args, **kwargs: P.kwargs) -> R:
        answer: R = getattr(getattr(self, room), name)(*args, **kwargs)
        return answer

    hand_over.__name__ = hand_over.__qualname__ = name
    hand_over.__doc__ = method.__doc__
    return hand_over


class LeaderboardService:
    """Every use case of the board, for the edges (routes, CLI, serve) to call."""

    def __init__(self, store: BoardStore, clock: Clock = utc_now,
                 archive: RecordArchive | None = None) -> None:
        self.store = store
        self.clock = clock
        self.archive = archive
        self._keeper = BoardKeeper(store, clock)

    # The rooms, each built on its first call.

    @cached_property
    def _pushing(self) -> Pushing:
        return Pushing(self._keeper, self.archive)

    @cached_property
    def _reading(self) -> Reading:
        return Reading(self._keeper)

    @cached_property
    def _racers(self) -> Racers:
        return Racers(self._keeper, self._reading)

    @cached_property
    def _managing(self) -> Managing:
        return Managing(self._keeper)

    @cached_property
    def _moderating(self) -> Moderating:
        return Moderating(self._keeper)

    @cached_property
    def _transfer(self) -> Transfer:
        return Transfer(self._keeper, self.archive)

    @cached_property
    def _seasons(self) -> Seasons:
        return Seasons(self._keeper)

    @cached_property
    def _aliases(self) -> Aliases:
        return Aliases(self._keeper)

    @cached_property
    def _results(self) -> Results:
        return Results(self._keeper)

    @cached_property
    def _webhooks(self) -> Webhooks:
        return Webhooks(self._keeper)

    @cached_property
    def _sharing(self) -> Sharing:
        return Sharing(self._reading, self._seasons, self.clock)

    push = _handed_to("_pushing", Pushing.push)
    me = _handed_to("_pushing", Pushing.me)
    claim_alias = _handed_to("_pushing", Pushing.claim_alias)

    boards = _handed_to("_reading", Reading.boards)
    boards_page = _handed_to("_reading", Reading.boards_page)
    board_page = _handed_to("_reading", Reading.board_page)
    board_pages = _handed_to("_reading", Reading.board_pages)
    board_tag = _handed_to("_reading", Reading.board_tag)
    board_version = _handed_to("_reading", Reading.board_version)

    racer = _handed_to("_racers", Racers.racer)
    compare = _handed_to("_racers", Racers.compare)
    insights = _handed_to("_racers", Racers.insights)
    history = _handed_to("_racers", Racers.history)
    history_page = _handed_to("_racers", Racers.history_page)
    status = _handed_to("_racers", Racers.status)

    create_board = _handed_to("_managing", Managing.create_board)
    update_board = _handed_to("_managing", Managing.update_board)
    close_board = _handed_to("_managing", Managing.close_board)
    delete_board = _handed_to("_managing", Managing.delete_board)
    restore_board = _handed_to("_managing", Managing.restore_board)
    rebuild_ranks = _handed_to("_managing", Managing.rebuild_ranks)

    remove_entry = _handed_to("_moderating", Moderating.remove_entry)
    ban = _handed_to("_moderating", Moderating.ban)
    unban = _handed_to("_moderating", Moderating.unban)
    audit = _handed_to("_moderating", Moderating.audit)

    export_page = _handed_to("_transfer", Transfer.export_page)
    export_lines = _handed_to("_transfer", Transfer.export_lines)
    import_board = _handed_to("_transfer", Transfer.import_board)
    import_submission = _handed_to("_transfer", Transfer.import_submission)
    bulk_import = _handed_to("_transfer", Transfer.bulk_import)
    recheck_page = _handed_to("_transfer", Transfer.recheck_page)

    assign_alias = _handed_to("_aliases", Aliases.assign_alias)
    release_alias = _handed_to("_aliases", Aliases.release_alias)
    aliases = _handed_to("_aliases", Aliases.aliases)
    alias_audit = _handed_to("_aliases", Aliases.alias_audit)

    create_season = _handed_to("_seasons", Seasons.create_season)
    update_season = _handed_to("_seasons", Seasons.update_season)
    add_round = _handed_to("_seasons", Seasons.add_round)
    remove_round = _handed_to("_seasons", Seasons.remove_round)
    set_final = _handed_to("_seasons", Seasons.set_final)
    clear_final = _handed_to("_seasons", Seasons.clear_final)
    close_season = _handed_to("_seasons", Seasons.close_season)
    reopen_season = _handed_to("_seasons", Seasons.reopen_season)
    seasons = _handed_to("_seasons", Seasons.seasons)
    seasons_page = _handed_to("_seasons", Seasons.seasons_page)
    season = _handed_to("_seasons", Seasons.season)
    board_seasons = _handed_to("_seasons", Seasons.board_seasons)
    laps_page = _handed_to("_results", Results.laps_page)
    run_laps = _handed_to("_results", Results.run_laps)

    racer_card_svg = _handed_to("_sharing", Sharing.racer_card_svg)
    racer_card = _handed_to("_sharing", Sharing.racer_card)
    season_card_svg = _handed_to("_sharing", Sharing.season_card_svg)
    season_card = _handed_to("_sharing", Sharing.season_card)

    add_webhook = _handed_to("_webhooks", Webhooks.add_webhook)
    webhooks = _handed_to("_webhooks", Webhooks.webhooks)
    remove_webhook = _handed_to("_webhooks", Webhooks.remove_webhook)
    test_webhook = _handed_to("_webhooks", Webhooks.test_webhook)

    @property
    def page_shelf(self) -> PageShelf | None:
        """Where the store keeps boards' pages as bytes, for every process reading the board
        (None: each process keeps its own; see ``routes.standings``)."""
        return self.store.pages

    def listen(self, listener: Callable[[EntryChange], None] | None) -> None:
        """Tell ``listener`` of every entry a push improves, as it happens (None: no one)."""
        self._keeper.listener = listener

    def keep_standings_after_pushes(self, keeper: StandingsKeeper | None) -> None:
        """After each push that improves a board, hand ``keeper`` the board and its first
        ``keeper.top`` entries, read once: the push's receipt is made from the same read
        (None: no one keeps them)."""
        self._keeper.standings_keeper = keeper
