"""What keeps `homemodel db serve` safe: the Host allow-list (against DNS rebinding), the
response headers (no sniffing, no inline script, no framing), a path check after
normalising, an explicit MIME map, conditional file responses, one log line per failure,
and a deadline for a request's headers (so half-sent requests cannot pile up)."""

from __future__ import annotations

import base64
import hashlib
import ipaddress
import logging
import os
import posixpath
import re
import socket
from collections.abc import Iterable
from dataclasses import dataclass
from email.utils import parsedate
from pathlib import Path

from starlette.datastructures import Headers
from starlette.exceptions import HTTPException
from starlette.responses import FileResponse, PlainTextResponse, Response
from starlette.staticfiles import NotModifiedResponse
from starlette.types import ASGIApp, Message, Receive, Scope, Send
from uvicorn.protocols.http.h11_impl import H11Protocol

logger = logging.getLogger(__name__)

# Independent of the machine's /etc/mime.types (a glb was model/gltf-binary only where it said so).
MIME_TYPES = {
    ".html": "text/html; charset=utf-8",
    ".js": "text/javascript; charset=utf-8",
    ".mjs": "text/javascript; charset=utf-8",
    ".css": "text/css; charset=utf-8",
    ".json": "application/json",
    ".glb": "model/gltf-binary",
    ".gltf": "model/gltf+json",
    ".bin": "application/octet-stream",
    ".png": "image/png",
    ".jpg": "image/jpeg",
    ".jpeg": "image/jpeg",
    ".webp": "image/webp",
    ".ktx2": "image/ktx2",
    ".svg": "image/svg+xml",
    ".obj": "model/obj",
    ".mtl": "model/mtl",
    ".stl": "model/stl",
    ".dae": "model/vnd.collada+xml",
    ".urdf": "application/xml",
    ".xml": "application/xml",
    ".yaml": "text/plain; charset=utf-8",
    ".txt": "text/plain; charset=utf-8",
    ".wasm": "application/wasm",
}
REASON_KEY = "homemodel.reason"  # where a handler leaves the reason for its 4xx, for the log line
MAX_NAME_BYTES = 255  # one path component, as file systems allow
MAX_PATH_BYTES = 1024
_BAD_CHARS = re.compile(r"[\x00-\x1f\x7f\\]")


def media_type(path: Path) -> str:
    return MIME_TYPES.get(path.suffix.lower(), "application/octet-stream")


def content_security_policy(inline_script_hashes: Iterable[str] = ()) -> str:
    """No inline script but the page's import map, pinned by its hash; everything from here.
    blob: is where three.js's GLTFLoader puts a glb's embedded images."""
    scripts = " ".join(["'self'", *(f"'sha256-{h}'" for h in inline_script_hashes)])
    return (
        f"default-src 'none'; script-src {scripts}; style-src 'self'; img-src 'self' data: blob:; "
        "connect-src 'self' blob:; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"
    )


def script_hash(text: str) -> str:
    return base64.b64encode(hashlib.sha256(text.encode()).digest()).decode()


def safe_file(root: Path, relative: str, *, allowed: tuple[str, ...] = ()) -> Path:
    """The file `root/relative`, checked after normalising: no control bytes or backslashes,
    no over-long names, nothing outside `root` (`..`, absolute paths, symlinks out or in a
    loop), and with `allowed`, only below one of those folders. Anything else is a 4xx."""
    if _BAD_CHARS.search(relative):
        raise HTTPException(400, "bad character in the path")
    if len(relative.encode()) > MAX_PATH_BYTES or any(len(p.encode()) > MAX_NAME_BYTES for p in relative.split("/")):
        raise HTTPException(414, "path or file name too long")
    normal = posixpath.normpath("/" + relative).lstrip("/")
    if normal != relative:
        raise HTTPException(404)  # `..`, `.` or `//` segments: browsers never send them
    if allowed and not any(normal.startswith(part.rstrip("/") + "/") for part in allowed):
        raise HTTPException(404)
    base = Path(os.path.realpath(root))
    try:
        path = Path(os.path.realpath(base / normal, strict=True))
    except (OSError, RuntimeError):  # missing, a symlink loop, a name the OS refuses
        raise HTTPException(404) from None
    if not path.is_relative_to(base) or not path.is_file():
        raise HTTPException(404)
    return path


def file_response(request_headers: Headers, path: Path) -> Response:
    """The file with ETag and Last-Modified, or 304 when the client's copy is current."""
    try:
        stat = path.stat()
    except OSError:
        raise HTTPException(404) from None
    response = FileResponse(path, media_type=media_type(path), stat_result=stat)
    response.headers["cache-control"] = "no-cache"  # may keep it, must ask (ETag) first
    if _not_modified(response.headers, request_headers):
        return NotModifiedResponse(response.headers)
    return response


def _not_modified(response_headers: Headers, request_headers: Headers) -> bool:
    if if_none_match := request_headers.get("if-none-match"):  # it wins over If-Modified-Since
        tags = [tag.strip().removeprefix("W/") for tag in if_none_match.split(",")]
        return "*" in tags or response_headers["etag"] in tags
    since = request_headers.get("if-modified-since")
    if since is None:
        return False
    since_time, modified_time = parsedate(since), parsedate(response_headers["last-modified"])
    return since_time is not None and modified_time is not None and modified_time <= since_time


def _host_port(value: str) -> tuple[str, int | None]:
    value = value.strip().lower()
    if value.startswith("["):  # [::1]:8765
        host, _, rest = value[1:].partition("]")
        port = rest.removeprefix(":")
    else:
        host, _, port = value.rpartition(":") if value.count(":") == 1 else (value, "", "")
    if port and not port.isdigit():
        raise ValueError(value)
    return host.rstrip("."), int(port) if port else None


@dataclass(frozen=True)
class HostAllowList:
    """The Host headers a request may carry: (host, port) pairs (port None: no port given)
    and, for a server on a wildcard address, any IP address with its port (DNS rebinding
    needs a name: an address typed by a user is never an attacker's)."""

    pairs: frozenset[tuple[str, int | None]]
    any_address_port: int | None = None

    def allows(self, host_header: str | None) -> bool:
        if host_header is None:
            return False
        try:
            host, port = _host_port(host_header)
        except ValueError:
            return False
        if (host, port) in self.pairs:
            return True
        return self.any_address_port is not None and port in (None, self.any_address_port) and _is_address(host)


def _is_address(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def allowed_hosts(listen_host: str, port: int, extra: Iterable[str] = ()) -> HostAllowList:
    """The address listened on (a wildcard address: loopback, this machine's names and any
    address), `localhost` for loopback, and `extra` (as `name` or `name:port`), each with or
    without the port."""
    names = {listen_host.strip("[]").lower()}
    try:
        address = ipaddress.ip_address(listen_host.strip("[]"))
    except ValueError:
        address = None
    if address is not None and (address.is_loopback or address.is_unspecified):
        names |= {"localhost", "127.0.0.1", "::1"}
    if address is not None and address.is_unspecified:
        names |= {socket.gethostname().lower(), socket.getfqdn().lower()}
    pairs = {(n, p) for n in names for p in (None, port)}
    for item in extra:
        host, item_port = _host_port(item)
        pairs |= {(host, item_port)} if item_port else {(host, None), (host, port)}
    return HostAllowList(frozenset(pairs), port if address is not None and address.is_unspecified else None)


class Guard:
    """Outermost ASGI middleware: refuses a Host not on the allow-list (421), adds the
    security headers to every response, and turns any exception into a 500 with one log line
    (never a dropped connection or a traceback)."""

    def __init__(self, app: ASGIApp, *, hosts: HostAllowList, csp: str) -> None:
        self.app = app
        self.hosts = hosts
        self.extra_headers = [
            (b"x-content-type-options", b"nosniff"),
            (b"content-security-policy", csp.encode()),
            (b"referrer-policy", b"no-referrer"),
            (b"x-frame-options", b"DENY"),
            (b"cross-origin-resource-policy", b"same-origin"),
        ]

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        status = None

        async def send_with_headers(message: Message) -> None:
            nonlocal status
            if message["type"] == "http.response.start":
                status = message["status"]
                message["headers"] = [*message.get("headers", []), *self.extra_headers]
            await send(message)

        request = f"{scope['method']} {scope['path']!r}"
        if not self.hosts.allows(Headers(scope=scope).get("host")):
            logger.warning("%s 421: refused Host %r", request, Headers(scope=scope).get("host"))
            await PlainTextResponse("Misdirected Request: this Host is not served here", 421)(scope, receive, send_with_headers)
            return
        try:
            await self.app(scope, receive, send_with_headers)
        except Exception as exc:  # noqa: BLE001 (any failure becomes a 500 and one line)
            logger.error("%s 500: %s: %s", request, type(exc).__name__, exc)
            if status is None:
                await PlainTextResponse("Internal Server Error", 500)(scope, receive, send_with_headers)
            return
        if status is not None and status >= 400:
            logger.warning("%s %d: %s", request, status, scope.get(REASON_KEY, "refused"))


class DeadlineH11Protocol(H11Protocol):
    """uvicorn's HTTP/1.1 protocol with a deadline for each request's headers (uvicorn times
    out only idle keep-alive connections): a client that has not sent a whole request
    `timeout_keep_alive` seconds after connecting, or after its last response, is closed, as is
    one that has read nothing of a response for that long.
    And when the connections near uvicorn's `limit_concurrency` (past it, every request gets
    503), the ones waiting longest for a request are closed to make room, so clients that
    hold connections half-sent cannot stop the service for others."""

    ROOM = 0.8  # the share of limit_concurrency past which waiting connections make room
    GRACE_S = 0.5

    def connection_made(self, transport) -> None:  # noqa: ANN001 (asyncio.Transport)
        super().connection_made(transport)
        self._write_paused_at: float | None = None  # since when the client reads nothing we send
        self._arm_deadline()
        self._make_room()

    def _arm_deadline(self) -> None:
        self._waiting_since = self.loop.time()
        self._deadline = self.loop.call_later(self.timeout_keep_alive, self._deadline_passed)

    def _waiting(self) -> bool:
        """No request of this connection is being answered (it waits for the client)."""
        return (self.cycle is None or self.cycle.response_complete) and not self.transport.is_closing()

    def _deadline_passed(self) -> None:
        stalled = self._write_paused_at is not None and self.loop.time() - self._write_paused_at >= self.timeout_keep_alive
        if self._waiting() or stalled:  # no request sent, or a response not read, in time
            self.transport.close()
        elif not self.transport.is_closing():
            self._arm_deadline()  # the app is answering: that is not the client's delay

    def pause_writing(self) -> None:
        super().pause_writing()
        self._write_paused_at = self.loop.time()

    def resume_writing(self) -> None:
        super().resume_writing()
        self._write_paused_at = None

    def _make_room(self) -> None:
        if self.limit_concurrency is None:
            return
        still_open = [c for c in self.connections if not c.transport.is_closing()]
        excess = len(still_open) - int(self.limit_concurrency * self.ROOM)
        if excess <= 0:
            return
        # A client that has just connected gets a moment to send its request.
        since = self.loop.time() - self.GRACE_S
        waiting = [
            c for c in still_open
            if isinstance(c, DeadlineH11Protocol) and c._waiting() and c._waiting_since < since
        ]  # fmt: skip
        for connection in sorted(waiting, key=lambda c: c._waiting_since)[:excess]:
            connection.transport.close()

    def on_response_complete(self) -> None:
        self._deadline.cancel()
        super().on_response_complete()
        if not self.transport.is_closing():
            self._arm_deadline()

    def connection_lost(self, exc: Exception | None) -> None:
        self._deadline.cancel()
        super().connection_lost(exc)
