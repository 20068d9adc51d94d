"""`homemodel db serve`: the database's web page on localhost, from the standard library's
HTTP server. Everything it sends is local: the page in `web/`, three.js from the
`tools/node_modules` the Makefile installs (never fetched at run time), the index as JSON,
and the model folders' files.
"""

from __future__ import annotations

import json
import mimetypes
from functools import partial
from http import HTTPStatus
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import unquote, urlparse

from articulation.gate.gltf import TOOLS_DIR
from homemodel.app.database.entry_build import ENTRY_FILE
from homemodel.app.database.index import MODELS_DIR, ModelIndex
from homemodel.core.errors import InputError

WEB_DIR = Path(__file__).resolve().parent / "web"
THREE_DIR = TOOLS_DIR / "node_modules" / "three"
# Only these parts of three.js are served: the module build and the example add-ons' modules.
THREE_PARTS = ("build", "examples/jsm")


def _inside(root: Path, relative: str) -> Path | None:
    """`root / relative` if it is a file inside `root` (no `..` escapes), else None."""
    path = (root / relative).resolve()
    return path if path.is_relative_to(root.resolve()) and path.is_file() else None


def map_tree(map_path: Path, db_dir: Path, entry_ids: set[str]) -> dict:
    """The semantic map as nested {id, kind, type, model, children}; `model` is the database
    entry an object's model comes from (its model_ref inside DIR/models/<id>, or its own id)."""
    from semantic_map import load_map

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


class _Handler(SimpleHTTPRequestHandler):
    def __init__(self, *args, db_dir: Path, map_path: Path | None, **kwargs) -> None:  # noqa: ANN002, ANN003
        self.db_dir = db_dir
        self.map_path = map_path
        super().__init__(*args, directory=str(WEB_DIR), **kwargs)

    def log_message(self, format: str, *args: object) -> None:  # noqa: A002 (the base class's name)
        pass  # the library never prints; the command says where it serves

    def _json(self, data: object, status: HTTPStatus = HTTPStatus.OK) -> None:
        body = json.dumps(data).encode()
        self.send_response(status)
        self.send_header("Content-Type", "application/json")
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def _file(self, path: Path | None) -> None:
        if path is None:
            self.send_error(HTTPStatus.NOT_FOUND)
            return
        body = path.read_bytes()
        kind = "text/javascript" if path.suffix == ".js" else mimetypes.guess_type(path.name)[0] or "application/octet-stream"
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", kind)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", "no-store")
        self.end_headers()
        self.wfile.write(body)

    def do_GET(self) -> None:  # noqa: N802 (the base class's name)
        route = unquote(urlparse(self.path).path)
        if route == "/api/models":
            with ModelIndex(self.db_dir) as index:
                self._json([vars(row) for row in index.rows()])
        elif route.startswith("/api/models/"):
            with ModelIndex(self.db_dir) as index:
                row = index.get(route.removeprefix("/api/models/"))
            if row is None:
                self._json({"error": "no such entry"}, HTTPStatus.NOT_FOUND)
                return
            entry = _inside(self.db_dir, f"{row.path}/{ENTRY_FILE}") if row.path else None
            validation = json.loads(entry.read_text()).get("validation") if entry else None
            self._json({**vars(row), "validation": validation})
        elif route == "/api/map":
            if self.map_path is None:
                self._json(None)
                return
            with ModelIndex(self.db_dir) as index:
                ids = set(index.keys())
            self._json(map_tree(self.map_path, self.db_dir, ids))
        elif route.startswith("/db/"):
            self._file(_inside(self.db_dir / MODELS_DIR, route.removeprefix("/db/")))
        elif route.startswith("/vendor/three/"):
            relative = route.removeprefix("/vendor/three/")
            allowed = any(relative.startswith(part + "/") for part in THREE_PARTS)
            self._file(_inside(THREE_DIR, relative) if allowed else None)
        else:
            super().do_GET()


def make_server(db_dir: Path, *, host: str = "127.0.0.1", port: int = 8765, map_path: Path | None = None) -> ThreadingHTTPServer:
    """A server (not yet serving) for the database at `db_dir`; port 0 picks a free port."""
    db_dir = Path(db_dir)
    ModelIndex(db_dir).close()  # a missing database fails here, before the port is taken
    if not (THREE_DIR / "build" / "three.module.js").is_file():
        raise InputError(f"{THREE_DIR}: three.js is not installed; run `make setup`")
    if map_path is not None:
        from semantic_map import load_map

        load_map(map_path)  # a bad map fails now
    handler = partial(_Handler, db_dir=db_dir, map_path=map_path)
    try:
        return ThreadingHTTPServer((host, port), handler)
    except OSError as exc:
        raise InputError(f"cannot listen on {host}:{port}: {exc.strerror}") from None
