"""The organisers' hand on racers' aliases: reserve an alias for a racer who has not signed in
yet (a season's racers in one command), give an alias to a sign-in, release one; every change
in the aliases' audit trail.

An alias is held by one sign-in (its principal). A racer's first stored push, or
`PUT /me/alias`, claims an alias no one holds and that has no results yet; an alias with results
but no claim (pushed by an organiser, imported, pushed before sign-ins) and a reserved alias are
given out only here, or by `drboard invite`.
"""

from __future__ import annotations

from ..cursors import decode_page_cursor, page_cursor
from ..errors import AliasTaken, InvalidQuery, RacerNotFound
from ..identity import LOCAL_ORGANISER, Caller
from ..models.domain import AliasClaim
from ..models.organiser_views import AliasList, AliasView, AuditPage
from .boards import EVENT_ID, BoardKeeper, racer_key
from .paging import DEFAULT_PAGE, bad_cursor, check_limit
from .pushing import RESERVED, valid_alias

#: The audit trail of alias changes: kept like a board's, under an id no board can have.
ALIASES_AUDIT = "#aliases"


def alias_view(claim: AliasClaim) -> AliasView:
    return AliasView(alias=claim.alias, racer_key=claim.racer_key, principal=claim.principal,
                     reserved=claim.principal.startswith(RESERVED), claimed_at=claim.claimed_at)


class Aliases:
    def __init__(self, keeper: BoardKeeper) -> None:
        self.keeper = keeper
        self.store = keeper.store

    def assign_alias(self, alias: str, principal: str | None = None, replace: bool = False,
                     caller: Caller = LOCAL_ORGANISER) -> AliasView:
        """Give the alias to a sign-in (``principal``), or keep it reserved for its racer (no
        principal). An alias another sign-in holds moves only with ``replace``; a reservation
        gives way. Doing it again changes nothing."""
        alias = valid_alias(alias)
        key = racer_key(alias)
        target = principal or f"{RESERVED}{key}"
        if principal is not None and principal.startswith(RESERVED):
            raise InvalidQuery("a principal is a sign-in (`cognito:…`, `join:…`): give none to "
                               "reserve the alias")
        current = self.store.alias_holder(key)
        if current is not None and current.principal == target:
            return alias_view(current)
        if (current is not None and not current.principal.startswith(RESERVED)
                and principal is not None and not replace):
            raise AliasTaken(f"the alias {alias!r} is held by {current.principal}: give it to "
                             "another sign-in with replace (`--replace`)")
        if current is not None and principal is None:
            return alias_view(current)  # held already: a reservation takes nothing from anyone
        claim = AliasClaim(racer_key=key, alias=current.alias if current else alias,
                           principal=target, claimed_at=self.keeper.clock())
        previous = self.store.assign_alias(claim)
        was = f" (was {previous.principal})" if previous else ""
        if principal is None:
            self._audit("alias-reserve", caller, claim.alias, f"kept for its racer{was}")
        else:
            self._audit("alias-assign", caller, claim.alias, f"given to {principal}{was}")
        return alias_view(claim)

    def release_alias(self, alias: str, caller: Caller = LOCAL_ORGANISER) -> AliasView:
        """Free the alias from its sign-in or reservation: the next racer to claim it takes it
        (unless it has results, which only an organiser gives out)."""
        previous = self.store.release_alias(racer_key(alias))
        if previous is None:
            raise RacerNotFound(f"no one holds the alias {alias!r}")
        self._audit("alias-release", caller, previous.alias, f"from {previous.principal}")
        return alias_view(previous)

    def aliases(self, limit: int = DEFAULT_PAGE, cursor: str | None = None) -> AliasList:
        """The aliases held or reserved, by alias key, ``limit`` at a time."""
        check_limit(limit)
        with bad_cursor():
            page = self.store.aliases(decode_page_cursor("aliases", cursor), limit)
        return AliasList(aliases=[alias_view(claim) for claim in page.claims],
                         next_cursor=page_cursor("aliases", page.after))

    def alias_audit(self, cursor: str | None = None, limit: int = 100) -> AuditPage:
        """Every reservation, assignment and release of an alias, oldest first."""
        check_limit(limit)
        if cursor is not None and not EVENT_ID.match(cursor):
            raise InvalidQuery("the cursor is not one this board gave out")
        page = self.store.audit(ALIASES_AUDIT, cursor, limit)
        return AuditPage(board_id=ALIASES_AUDIT, events=page.events, next_cursor=page.after)

    def _audit(self, action: str, caller: Caller, alias: str, detail: str) -> None:
        self.keeper.audit(ALIASES_AUDIT, action, caller, racer=alias, detail=detail)  # type: ignore[arg-type]
