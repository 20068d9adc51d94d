"""`homemodel db serve`: the database's web page and its API, a Starlette app on uvicorn.
Everything it sends is local: the page in `web/`, three.js from the node_modules folder the
Makefile installs (found by `homemodel.core.node_packages`; never fetched at run time), the
index as JSON pages, and the model folders' files. What keeps it safe is in `server_security`.
"""

from __future__ import annotations

import ipaddress
import json
import re
import socket
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import JSONResponse, PlainTextResponse, Response
from starlette.routing import Route

from homemodel.app.database.entry_build import ENTRY_FILE
from homemodel.app.database.index import MODELS_DIR, ModelIndex
from homemodel.app.database.listing import Listing, ListQuery, finite_number, summary
from homemodel.app.database.server_security import (
    REASON_KEY,
    DeadlineH11Protocol,
    Guard,
    HostAllowList,
    allowed_hosts,
    content_security_policy,
    file_response,
    safe_file,
    script_hash,
)
from homemodel.core.errors import HomemodelError, InputError
from homemodel.core.node_packages import find_node_package, install_hint


WEB_DIR = Path(__file__).resolve().parent / "web"
WEB_FILES = ("index.html", "app.js", "viewer.js", "style.css")
# Only these parts of three.js are served: the module build and the example add-ons' modules.
THREE_PARTS = ("build", "examples/jsm")
_IMPORT_MAP = re.compile(r'<script type="importmap">(.*?)</script>', re.S)


@dataclass(kw_only=True)
class ServeOptions:
    """Where and how `db serve` listens. A client has `client_timeout_s` to send a request's
    headers (after connecting or its last response) and is then closed. Past 80 % of
    `max_connections` open at once, those waiting longest for a request are closed to make
    room; past `max_connections` busy ones, requests get 503."""

    host: str = "127.0.0.1"
    port: int = 8765  # 0: any free port
    allow_hosts: list[str] = field(default_factory=list)  # more names the Host header may give
    client_timeout_s: float = 10.0
    max_connections: int = 1000

    def check(self) -> None:
        if not 0 <= self.port <= 65535:
            raise InputError(f"--port {self.port}: not a port number (0-65535)")
        if self.client_timeout_s <= 0 or self.max_connections < 1:
            raise InputError(f"client_timeout_s {self.client_timeout_s}, max_connections {self.max_connections}: must be positive")
        for name in self.allow_hosts:
            if not re.fullmatch(r"[A-Za-z0-9.\-]+(:\d+)?|\[[0-9A-Fa-f:.]+\](:\d+)?", name):
                raise InputError(f"--allow-host {name!r}: not a host name, address or host:port")

    @property
    def is_loopback(self) -> bool:
        try:
            return ipaddress.ip_address(self.host.strip("[]")).is_loopback
        except ValueError:
            return self.host == "localhost"


def map_tree(map_path: Path, db_dir: Path, entry_ids: set[str]) -> dict:
    """The semantic map as nested {id, kind, type, model, children}; `model` is the database
    entry an object's model comes from (its model_ref inside DIR/models/<id>, or its own id)."""
    from homemodel.exchange.map_xml import load_map

    smap = load_map(map_path)
    models = (db_dir / MODELS_DIR).resolve()

    def entry_of(obj) -> str | None:  # noqa: ANN001 (a map object)
        if obj.model_ref:
            ref = (Path(map_path).resolve().parent / obj.model_ref).resolve()
            if ref.is_relative_to(models) and ref.relative_to(models).parts[0] in entry_ids:
                return ref.relative_to(models).parts[0]
        return obj.id if obj.id in entry_ids else None

    def small(obj) -> dict:  # noqa: ANN001
        return {"id": obj.id, "kind": f"small object ({obj.relation})", "type": obj.type, "model": entry_of(obj), "children": []}

    def large(obj) -> dict:  # noqa: ANN001
        children = [small(s) for s in obj.small_objects]
        return {"id": obj.id, "kind": "large object", "type": obj.type, "model": entry_of(obj), "children": children}

    rooms = [
        {"id": room.id, "kind": "room", "type": room.name, "model": None, "children": [large(o) for o in room.objects]}
        for room in smap.apartment.rooms
    ]
    apartment = smap.apartment
    return {"id": apartment.id, "kind": "apartment", "type": apartment.name, "model": None, "children": rooms}


def _json(data: object) -> JSONResponse:
    return JSONResponse(data, headers={"cache-control": "no-store"})


def _error(request: Request, message: str, status: int) -> JSONResponse:
    """{"error": message} with `status`; the message is the reason in the log line."""
    request.scope[REASON_KEY] = message
    return JSONResponse({"error": message}, status, headers={"cache-control": "no-store"})


def _validation_report(db_dir: Path, row_path: object) -> str | None:
    """The gate's report from the entry's folder, or None when it cannot be read."""
    if not isinstance(row_path, str):
        return None
    try:
        entry = safe_file(db_dir, f"{row_path}/{ENTRY_FILE}")
        report = json.loads(entry.read_text()).get("validation")
    except (HTTPException, OSError, ValueError, AttributeError):
        return None
    return report if isinstance(report, str) else None


def _glb_url(row_path: object) -> str | None:
    """The URL of an entry's model.glb when the index names a folder under models/."""
    if not isinstance(row_path, str) or not row_path.startswith(f"{MODELS_DIR}/"):
        return None
    return "/db/" + quote(row_path.removeprefix(f"{MODELS_DIR}/") + "/model.glb")


def three_dir() -> Path:
    """The installed three.js package; an InputError saying how to install it when it is absent."""
    folder = find_node_package("three")
    if folder is None or not (folder / "build" / "three.module.js").is_file():
        raise InputError(install_hint("three"))
    return folder


def make_app(db_dir: Path, *, map_path: Path | None, hosts: HostAllowList) -> Guard:
    """The ASGI app: the page, the API (`/api/models?q=&status=&sort=&order=&offset=&limit=`,
    `/api/models/ID`, `/api/map`), model files under `/db/` and three.js under `/vendor/three/`."""
    three = three_dir()
    listing = Listing(db_dir)
    listing.query(ListQuery())  # read the index now, so the page's first list is quick
    page = (WEB_DIR / "index.html").read_text()
    csp = content_security_policy([script_hash(m) for m in _IMPORT_MAP.findall(page)])

    def web_file(request: Request) -> Response:
        name = request.path_params.get("name", "index.html")
        if name not in WEB_FILES:
            raise HTTPException(404)
        return file_response(request.headers, WEB_DIR / name)

    def models(request: Request) -> Response:
        params = request.query_params
        try:
            query = ListQuery(
                q=params.get("q", ""),
                status=params.get("status") or None,
                sort=params.get("sort", "id"),
                descending=params.get("order") == "desc",
                offset=int(params.get("offset", "0")),
                limit=int(params.get("limit", "100")),
            )
            return _json(listing.query(query))
        except ValueError as exc:
            return _error(request, f"not a number: {exc}", 400)
        except InputError as exc:
            return _error(request, str(exc), 400)

    def model(request: Request) -> Response:
        with ModelIndex(db_dir) as index:
            row = index.get(request.path_params["entry_id"])
        if row is None:
            return _error(request, "no such entry", 404)
        checks = [
            {"name": str(c.get("name")), "passed": bool(c.get("passed")), "detail": str(c.get("detail"))}
            for c in row.checks if isinstance(c, dict)
        ]  # fmt: skip
        return _json(
            summary(db_dir, vars(row))
            | {
                "glb": _glb_url(row.path),
                "built_at": str(row.built_at),
                "repairs": [str(r) for r in row.repairs],
                "checks": checks,
                "times_s": {str(k): finite_number(v) for k, v in row.times_s.items()},
                "validation": _validation_report(db_dir, row.path),
            }
        )

    def map_view(request: Request) -> Response:
        if map_path is None:
            return _json(None)
        with ModelIndex(db_dir) as index:
            ids = set(index.keys())
        try:
            return _json(map_tree(map_path, db_dir, ids))
        except HomemodelError as exc:
            return _error(request, str(exc), 500)

    def db_file(request: Request) -> Response:
        return file_response(request.headers, safe_file(db_dir / MODELS_DIR, request.path_params["path"]))

    def three_file(request: Request) -> Response:
        path = safe_file(three, request.path_params["path"], allowed=THREE_PARTS)
        return file_response(request.headers, path)

    async def http_error(request: Request, exc: Exception) -> Response:
        assert isinstance(exc, HTTPException)
        request.scope[REASON_KEY] = exc.detail
        return PlainTextResponse(exc.detail, exc.status_code)

    routes = [
        Route("/", web_file),
        Route("/{name:str}", web_file),
        Route("/api/models", models),
        Route("/api/models/{entry_id:path}", model),
        Route("/api/map", map_view),
        Route("/db/{path:path}", db_file),
        Route("/vendor/three/{path:path}", three_file),
    ]
    app = Starlette(routes=routes, exception_handlers={HTTPException: http_error})
    return Guard(app, hosts=hosts, csp=csp)


class DatabaseServer:
    """A bound, not yet serving, uvicorn server for the database page."""

    def __init__(self, db_dir: Path, options: ServeOptions, map_path: Path | None) -> None:
        import uvicorn

        family = socket.AF_INET6 if ":" in options.host.strip("[]") else socket.AF_INET
        # IPPROTO_TCP named: asyncio turns Nagle off (TCP_NODELAY) only on sockets that say it,
        # and with Nagle on, each response's body waited 40 ms for the client's delayed ACK.
        self.socket = socket.socket(family, socket.SOCK_STREAM, socket.IPPROTO_TCP)
        try:
            self.socket.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self.socket.bind((options.host.strip("[]"), options.port))
            self.socket.listen(1024)
        except OSError as exc:
            self.socket.close()
            raise InputError(f"cannot listen on {options.host}:{options.port}: {exc.strerror}") from None
        self.port: int = self.socket.getsockname()[1]
        hosts = allowed_hosts(options.host, self.port, options.allow_hosts)
        config = uvicorn.Config(
            make_app(db_dir, map_path=map_path, hosts=hosts),
            http=DeadlineH11Protocol,
            ws="none",
            lifespan="off",
            timeout_keep_alive=options.client_timeout_s,
            limit_concurrency=options.max_connections,
            h11_max_incomplete_event_size=16 * 1024,  # a request line and headers
            server_header=False,
            log_config=None,
            access_log=False,  # the Guard logs each refused or failed request, once
        )
        self._server = uvicorn.Server(config)

    def serve_forever(self) -> None:
        """Serve until `shutdown()` (from another thread) or Ctrl-C."""
        self._server.run(sockets=[self.socket])

    def shutdown(self) -> None:
        self._server.should_exit = True

    def close(self) -> None:
        self.socket.close()


def make_server(db_dir: Path, options: ServeOptions | None = None, *, map_path: Path | None = None) -> DatabaseServer:
    """A server, bound and not yet serving, for the database at `db_dir`."""
    options = options or ServeOptions()
    options.check()
    db_dir = Path(db_dir)
    ModelIndex(db_dir).close()  # a missing database fails here, before the port is taken
    three_dir()  # a missing three.js fails here, before the port is taken
    if map_path is not None:
        from homemodel.exchange.map_xml import load_map

        load_map(map_path)  # a bad map fails now
    return DatabaseServer(db_dir, options, map_path)
