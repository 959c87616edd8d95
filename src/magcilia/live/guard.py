"""The dashboard obeys only its own page: Host, Origin and a per-run token, checked before any
request reaches the app (a plain ASGI middleware, :class:`OwnPageOnly`; no package needed).

What it stops, and how:

- **DNS rebinding.** A page on ``evil.example`` points its own name at 127.0.0.1; the browser
  then calls the dashboard as ``evil.example`` and, to the browser, that is the page's own origin.
  The ``Host`` header still says ``evil.example``: every request (page, files, API, WebSocket)
  whose Host does not name this server is refused. It names this server when it is an IP address
  (a rebinding needs a name), ``localhost``, or, when the dashboard listens beyond this computer,
  the name given with ``--host`` or this computer's own name. The port is not compared, so an SSH
  tunnel to another local port still works.
- **Cross-site requests.** Any page may POST to 127.0.0.1 (a form, or a fetch with a plain-text
  body: no preflight), and open a WebSocket to it. Browsers say where such a request comes from
  in ``Origin``: a request whose Origin is present and is not the page's own (``http://`` and
  the same host and port as ``Host``), or is ``null`` (sandboxed frames, ``file:`` pages), is
  refused, whatever its method, and so is such a WebSocket handshake.
- **Commands need the token.** Every request other than GET and HEAD (``POST /api/tare``,
  ``POST /api/record``) must carry the per-run token in the ``X-Magcilia-Token`` header. Only
  the served page holds it (a ``<meta name="magcilia-token">`` in the HTML, served with
  ``Cache-Control: no-store``); other sites cannot read the page (the server sends no CORS
  headers), and a custom header on a cross-site fetch needs a preflight that nothing here
  answers.

A request **without** Origin is let through the Origin check: browsers send Origin with every
POST and WebSocket handshake, so it does not come from a browser's cross-site request but from a
script on a computer that reaches the server (``curl``, Python); its commands still need the
token, which it reads from the page like the browser does. The token is not a password: anyone
who can load the page (everyone on the network with ``--host 0.0.0.0``) can read it.

Refused HTTP requests get ``403`` with ``{"error": "why"}``; a refused WebSocket handshake is
closed before it is accepted (the server answers ``403``).
"""

from __future__ import annotations

import ipaddress
import json
import secrets
import socket
from collections.abc import Awaitable, Callable, MutableMapping
from dataclasses import dataclass, field
from typing import Any
from urllib.parse import urlsplit

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

#: the request header that carries the token (lower case, as ASGI gives header names)
TOKEN_HEADER = "x-magcilia-token"
#: the ``name`` of the page's ``<meta>`` tag that holds the token
TOKEN_META = "magcilia-token"
#: methods that never act (everything else is a command and needs the token)
SAFE_METHODS = frozenset({"GET", "HEAD"})
#: hosts that only this computer reaches
LOOPBACK = frozenset({"127.0.0.1", "localhost", "::1"})
#: addresses that listen on every interface
WILDCARD = frozenset({"0.0.0.0", "::", ""})


def _host_name(host: str) -> str:
    """``host`` without brackets, the trailing dot and case."""
    return host.strip().strip("[]").rstrip(".").lower()


def split_host(value: str) -> tuple[str, int | None]:
    """The name and port of a ``Host`` header value (``[::1]:8050`` → ``("::1", 8050)``).

    Raises
    ------
    ValueError
        If the port is not a number.
    """
    value = value.strip()
    if value.startswith("["):
        name, _, rest = value[1:].partition("]")
        port = rest[1:] if rest.startswith(":") else ("" if not rest else "x")
    elif value.count(":") == 1:
        name, port = value.split(":")
    else:  # a bare name, or a bare IPv6 address (not a valid Host, refused by the name check)
        name, port = value, ""
    return _host_name(name), int(port) if port else None


def _is_address(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


@dataclass(frozen=True)
class Guard:
    """Which Host names serve the dashboard and the token its commands need.

    Parameters
    ----------
    names : frozenset of str
        Host names (lower case, no port) that name this server besides IP addresses.
    token : str
        The per-run secret that commands carry in ``X-Magcilia-Token``.
    """

    names: frozenset[str] = frozenset({"localhost"})
    token: str = field(default_factory=lambda: secrets.token_urlsafe(32), repr=False)

    @classmethod
    def serving(cls, host: str = "127.0.0.1", token: str | None = None) -> Guard:
        """The guard of a dashboard that listens on ``host``, with a fresh token (or ``token``).

        On this computer only (127.0.0.1, localhost, ::1) the names are ``localhost`` and IP
        addresses; beyond it, also ``host`` itself and this computer's name.
        """
        names = {"localhost"}
        name = _host_name(host)
        if name not in LOOPBACK:
            if name not in WILDCARD and not _is_address(name):
                names.add(name)
            for own in (socket.gethostname(), socket.getfqdn()):
                if own:
                    names.add(_host_name(own))
        return cls(frozenset(names), token if token is not None else secrets.token_urlsafe(32))

    def host_allowed(self, host: str | None) -> bool:
        """Whether a ``Host`` header value names this server (its port is not compared)."""
        if not host:
            return False
        try:
            name, _ = split_host(host)
        except ValueError:
            return False
        return name in self.names or _is_address(name)

    @staticmethod
    def same_origin(origin: str, host: str) -> bool:
        """Whether ``origin`` is the page served as ``host``: ``http://`` and the same host
        and port (80 where none is given)."""
        try:
            parts = urlsplit(origin)
            if parts.scheme != "http" or parts.path or parts.query or parts.username:
                return False
            mine, theirs = split_host(host), split_host(parts.netloc)
        except ValueError:
            return False
        return (mine[0], mine[1] or 80) == (theirs[0], theirs[1] or 80)

    def token_ok(self, token: str | None) -> bool:
        """Whether ``token`` is this run's token (compared in constant time)."""
        return token is not None and secrets.compare_digest(token.encode(), self.token.encode())

    def refusal(self, scope: Scope) -> str | None:
        """Why the HTTP or WebSocket request ``scope`` is refused, in one line (None: allowed)."""
        headers: dict[str, str] = {}
        for key, value in scope.get("headers", ()):
            headers.setdefault(key.decode("latin-1").lower(), value.decode("latin-1"))
        host = headers.get("host")
        if not self.host_allowed(host):
            return (f"Host {host!r} does not name this dashboard (a page on another site that "
                    "points its name here); open it by its address, e.g. http://127.0.0.1:PORT/")
        assert host is not None
        origin = headers.get("origin")
        if origin is not None and not self.same_origin(origin, host):
            return (f"requests from another page (Origin {origin!r}) are refused; use the "
                    "dashboard's own page")
        if scope["type"] == "http" and scope.get("method", "GET") not in SAFE_METHODS \
                and not self.token_ok(headers.get(TOKEN_HEADER)):
            what = "wrong" if TOKEN_HEADER in headers else "missing"
            return (f"{what} dashboard token: commands are taken only from the page this "
                    f"server served (reload it; scripts send the page's <meta name="
                    f"\"{TOKEN_META}\"> as the header X-Magcilia-Token)")
        return None


class OwnPageOnly:
    """ASGI middleware: refuse what :meth:`Guard.refusal` refuses, pass the rest to ``app``.

    Parameters
    ----------
    app : ASGI app
        The dashboard.
    guard : Guard
        Its names and token.
    """

    def __init__(self, app: ASGIApp, guard: Guard) -> None:
        self.app = app
        self.guard = guard

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        why = self.guard.refusal(scope)
        if why is None:
            await self.app(scope, receive, send)
        elif scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008, "reason": ""})
        else:
            body = json.dumps({"error": why}).encode()
            await send({"type": "http.response.start", "status": 403, "headers": [
                (b"content-type", b"application/json"), (b"cache-control", b"no-store"),
                (b"content-length", str(len(body)).encode())]})
            await send({"type": "http.response.body", "body": body})
