"""The station's doors (design.md §6): who may read the page and who may press Start.

A station can turn a motor, so every request passes three checks before the application sees it:

1. **Host** — the ``Host`` header must name the address the station serves (``--host`` and
   ``--port``; on loopback also ``localhost``). A page of another site whose name was re-pointed
   at 127.0.0.1 (DNS rebinding) is same-origin to the browser, but its requests still say
   ``Host: evil.example``: 403, for reading as for writing.
2. **Origin** — a state-changing request (anything but GET, HEAD, OPTIONS) must come from the
   station's own page: its ``Origin`` (else its ``Referer``) must be ``http://<an allowed
   host>``. A request naming another origin, or none, is 403.
3. **Page token** — the page is served with a fresh random token in ``<meta name="hil-csrf">``
   and its script sends it back in the ``X-HIL-CSRF`` header of every POST; a state-changing
   request without a token this station issued is 403. Another origin cannot read the page, so
   it cannot learn a token.

The access token (``hil.station.app.TokenGate``) comes after these: required off loopback,
allowed on loopback.
"""

from __future__ import annotations

import ipaddress
import secrets
from collections import OrderedDict
from urllib.parse import urlsplit

from starlette.responses import PlainTextResponse

#: Methods that change nothing (the only ones allowed without Origin and page token).
SAFE_METHODS = frozenset({"GET", "HEAD", "OPTIONS"})
#: The request header carrying the page token, and the page's meta element naming it.
CSRF_HEADER = "x-hil-csrf"
CSRF_META = "hil-csrf"


def allowed_hosts(host: str, port: int, extra: tuple[str, ...] = ()) -> frozenset[str]:
    """The ``Host`` header values that name this station: ``host:port`` (IPv6 in brackets),
    ``localhost:port`` too when serving on loopback, and each of ``extra`` (names the operators
    use for a non-loopback address). Port 80 may also be left out, as browsers do."""
    names = {host, *extra}
    try:
        address = ipaddress.ip_address(host)
    except ValueError:
        address = None
    if host == "localhost":
        names |= {"127.0.0.1"}
    elif address is not None and address.is_loopback:
        names |= {"localhost"}
    out = set()
    for name in names:
        try:
            literal = ipaddress.ip_address(name)
        except ValueError:
            literal = None
        name = f"[{name}]" if literal is not None and literal.version == 6 else name
        out.add(f"{name.lower()}:{port}")
        if port == 80:
            out.add(name.lower())
    return frozenset(out)


class PageTokens:
    """Tokens issued with the page, one per page load; the newest ``keep`` are valid (an old
    tab whose token was dropped is told to reload)."""

    def __init__(self, keep: int = 512) -> None:
        self.keep = keep
        self._issued: OrderedDict[str, None] = OrderedDict()

    def issue(self) -> str:
        token = secrets.token_urlsafe(32)
        self._issued[token] = None
        while len(self._issued) > self.keep:
            self._issued.popitem(last=False)
        return token

    def valid(self, token: str | None) -> bool:
        return bool(token) and token in self._issued


class StationGuard:
    """ASGI middleware applying the Host, Origin and page-token checks (module docstring)."""

    def __init__(self, app, hosts: frozenset[str], tokens: PageTokens) -> None:
        self.app, self.hosts, self.tokens = app, hosts, tokens
        self.origins = frozenset(f"http://{host}" for host in hosts)

    async def __call__(self, scope, receive, send) -> None:
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        refusal = self.refusal(scope)
        if refusal:
            response = PlainTextResponse(f"hil station: {refusal}", status_code=403)
            return await response(scope, receive, send)
        return await self.app(scope, receive, send)

    def refusal(self, scope) -> str | None:
        """Why this request is refused, or None."""
        headers = {}
        for key, value in scope.get("headers") or []:
            headers.setdefault(key.decode("latin-1").lower(), value.decode("latin-1"))
        host = headers.get("host", "").strip().lower()
        if host not in self.hosts:
            return (f"Host {host or '(none)'!r} is not this station's address "
                    f"({', '.join(sorted(self.hosts))})")
        if scope.get("method", "GET").upper() in SAFE_METHODS:
            return None
        origin = headers.get("origin")
        if origin is None and "referer" in headers:
            parts = urlsplit(headers["referer"])
            origin = f"{parts.scheme}://{parts.netloc}"
        if origin is None or origin.strip().lower() not in self.origins:
            return (f"a command must come from the station's own page (Origin "
                    f"{origin or '(none)'!r} is not {', '.join(sorted(self.origins))})")
        if not self.tokens.valid(headers.get(CSRF_HEADER)):
            return ("the page's token is missing or not this station's: reload the station's "
                    "page")
        return None
