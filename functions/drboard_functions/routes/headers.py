"""The HTTP headers the board's answers carry, and the ETags they are known by.

No model and no Powertools here: the pull function answers a kept page with these before it
loads the resolver (see :mod:`.kept`).
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable, Mapping

from drboard_assembler import __version__ as assembler_version

JSON = "application/json"
HTML = "text/html; charset=utf-8"
SVG = "image/svg+xml"
PNG = "image/png"
#: Every page's headers; its Content-Security-Policy comes from ``responses.page_answer`` (the
#: pages load nothing and run no script but their own inlined style and script, allowed by hash).
PAGE_HEADERS = {
    "X-Content-Type-Options": "nosniff",
    "Cache-Control": "no-store",
}

#: The Cache-Control of every public read's answer (and of no signed or organiser one): a CDN or
#: a browser may keep it two seconds, and answer it two more while it asks again, so a page that
#: changes with every push is at most a few seconds behind; errors are never kept. Viewers who
#: poll every two seconds cost the board one request per CDN location per two seconds.
PUBLIC_CACHE = "public, max-age=2, stale-while-revalidate=2"

#: Who may read the public routes from a page of another origin: anyone (the signed routes set
#: ``cors=False``). ``routes.app`` gives Powertools' resolver the same settings, and the answers
#: of kept pages carry the same headers (tests/unit/test_kept_pages.py holds them equal).
CORS_ORIGIN = "*"
CORS_HEADERS = ("Content-Type",)
CORS_MAX_AGE_S = 600
#: The CORS headers of a read's answer to a request that names its Origin, as the resolver adds
#: them (Powertools adds its default request headers to ours).
READ_CORS = {
    "Access-Control-Allow-Origin": CORS_ORIGIN,
    "Access-Control-Allow-Headers": ",".join(sorted(
        {"Authorization", "Content-Type", "X-Amz-Date", "X-Amz-Security-Token", "X-Api-Key",
         *CORS_HEADERS})),
    "Access-Control-Max-Age": str(CORS_MAX_AGE_S),
}


def api_version() -> str:
    """The distribution's version, as its packages write it out (tests/unit/test_openapi.py holds
    it equal to the installed distribution's): a Lambda bundle has no metadata to read, and
    looking for it costs a cold start more than the rest of building the resolver."""
    return assembler_version


def page_etag(tag: str, limit: int, cursor: str | None) -> str:
    """The ETag of one page of a board: the board's page tag, the page asked for, and the API's
    version (a new release may answer differently)."""
    query = hashlib.sha256(f"{limit}|{cursor or ''}".encode()).hexdigest()[:12]
    return f'"{api_version()}.{tag}.{query}"'


def etag_headers(etag: str) -> dict[str, str]:
    return {"ETag": etag, "Cache-Control": PUBLIC_CACHE}


def card_etag(svg: str, kind: str) -> str:
    """The ETag of a result card as SVG or PNG: its SVG's digest (the PNG is drawn from it)."""
    digest = hashlib.sha256(f"{api_version()}|{svg}".encode()).hexdigest()[:24]
    return f'"card.{kind}.{digest}"'


def card_headers(etag: str) -> dict[str, str]:
    """A card's answer's headers, 200 (with its Content-Type) or 304."""
    return etag_headers(etag) | {"X-Content-Type-Options": "nosniff"}


#: An SVG card opened on its own may load and run nothing.
SVG_POLICY = {"Content-Security-Policy": "default-src 'none'"}


def body_etag(body: str) -> str:
    """The ETag of a public answer that has none of its own: its body's digest."""
    return '"' + hashlib.sha256(body.encode("utf-8")).hexdigest()[:24] + '"'


def names_etag(if_none_match: str | None, etag: str) -> bool:
    """Whether an If-None-Match names the ETag (weakly: a CDN that compresses an answer hands its
    ETag on as ``W/"..."``)."""
    return bool(if_none_match) and any(
        tag.strip().removeprefix("W/") == etag for tag in str(if_none_match).split(","))


def origin_of(headers: Mapping[str, str], domain: str | None) -> str:
    """The origin a client used: its Host (API Gateway's domain name without one), https
    behind API Gateway's ``X-Forwarded-Proto``."""
    host = headers.get("host") or domain or "localhost"
    scheme = headers.get("x-forwarded-proto", "http").split(",")[0].strip()
    return f"{scheme}://{host}"


def header_values(raw: Iterable[tuple[bytes, bytes]], *names: bytes) -> dict[bytes, str]:
    """The named headers of an ASGI request (lower-case names), a repeated one's values joined."""
    found: dict[bytes, str] = {}
    for name, value in raw:
        name = name.lower()
        if name in names:
            text = value.decode("latin-1")
            found[name] = f"{found[name]},{text}" if name in found else text
    return found
