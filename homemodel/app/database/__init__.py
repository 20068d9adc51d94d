"""The model database: batch builds of every kind of source from one manifest, on local worker
processes or a Dask cluster, into `DIR/models/<id>/` and an SQLite index, `DIR/index.sqlite`;
queries, export and a web page.

- `manifest`: the manifest file and its entries (sweeps expanded into jobs);
- `content_key`: what decides whether an entry must be built again;
- `entry_build`: one entry in a worker (pipeline, gate, thumbnail, atomic store);
- `build`: the whole build (`dispatch`: its entries shared out; `local_workers`: this machine's
  worker processes, no Dask; `cluster`: a Dask scheduler's, with `--scheduler`);
- `index`: the SQLite index; `queries`: list, find, remove, export, `db:ID` references;
- `server` (with `server_security` and `listing`) and `web/`: the page `homemodel db serve` shows.
"""

from homemodel.app.database.build import DatabaseBuild, DatabaseBuildOptions, build_database
from homemodel.app.database.index import EntryRow, ModelIndex

__all__ = ["DatabaseBuild", "DatabaseBuildOptions", "EntryRow", "ModelIndex", "build_database"]
