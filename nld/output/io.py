"""Result tables on disk, with their provenance.

Two formats, chosen by the file suffix:

* ``.parquet``: the provenance is stored as JSON in the Arrow schema metadata under the key
  ``b"nld"``; a sidecar ``PATH.json`` with the same JSON is written too, for human reading.
* ``.csv``: the provenance is stored in the sidecar ``PATH.json`` (e.g. ``run.csv.json``).

Any other suffix -> :class:`~nld.errors.InputError` naming the allowed ones.
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd

from nld.errors import InputError

__all__ = ["SUFFIXES", "METADATA_KEY", "check_table_path", "sidecar_path", "save_table", "load_table",
           "provenance_json"]

SUFFIXES = (".csv", ".parquet")
METADATA_KEY = b"nld"


def check_table_path(path) -> Path:
    """The path as a Path if its suffix is one of :data:`SUFFIXES`, else InputError."""
    p = Path(path).expanduser()
    if p.suffix.lower() not in SUFFIXES:
        shown = p.suffix if p.suffix else "(none)"
        raise InputError(f"output file {str(path)!r}: unsupported suffix {shown}; "
                         f"allowed: {', '.join(SUFFIXES)}")
    return p


def sidecar_path(path) -> Path:
    """``run.csv`` -> ``run.csv.json``."""
    p = Path(path)
    return p.with_name(p.name + ".json")


def json_default(o):
    """JSON form of what json does not know: numpy scalars and arrays, paths, sets, frames (anything
    else: its str). The one converter of provenance and metadata (nld.sweeps.store uses it too)."""
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    if isinstance(o, pd.DataFrame):
        return o.to_dict(orient="list")
    return str(o)


def provenance_json(provenance: dict, indent: int | None = None) -> str:
    """JSON text of a provenance dict (numpy scalars and arrays, paths and the like made plain)."""
    return json.dumps(provenance if provenance is not None else {}, default=json_default, indent=indent,
                      allow_nan=True)


def write_atomic(path: Path, write) -> Path:
    """``write(tmp)`` then rename tmp to ``path``: readers see the whole file or none."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def save_table(df: pd.DataFrame, path, provenance: dict | None) -> Path:
    """Write ``df`` to ``path`` (``.parquet`` or ``.csv``) with its provenance; returns the path.

    Missing parent directories are created. An unsupported suffix or a file that cannot be written
    -> InputError (one line).
    """
    p = check_table_path(path)
    text = provenance_json(provenance)
    pretty = provenance_json(provenance, indent=2) + "\n"
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        if p.suffix.lower() == ".parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq
            table = pa.Table.from_pandas(df, preserve_index=False)
            meta = dict(table.schema.metadata or {})
            meta[METADATA_KEY] = text.encode("utf-8")
            table = table.replace_schema_metadata(meta)
            write_atomic(p, lambda tmp: pq.write_table(table, tmp))
        else:
            write_atomic(p, lambda tmp: df.to_csv(tmp, index=False))
        side = sidecar_path(p)
        write_atomic(side, lambda tmp: tmp.write_text(pretty, encoding="utf-8"))
    except OSError as e:
        raise InputError(f"cannot write {p}: {e.strerror or e}") from None
    return p


def load_table(path) -> tuple[pd.DataFrame, dict]:
    """Read a table written by :func:`save_table`: ``(DataFrame, provenance dict)``.

    For parquet the provenance comes from the schema metadata (the sidecar if the metadata lacks
    it); for CSV from the sidecar ``PATH.json`` ({} if there is none).
    """
    p = check_table_path(path)
    if not p.is_file():
        raise InputError(f"table file not found: {p}")
    prov = None
    try:
        if p.suffix.lower() == ".parquet":
            import pyarrow.parquet as pq
            table = pq.read_table(p)
            meta = table.schema.metadata or {}
            if METADATA_KEY in meta:
                prov = json.loads(meta[METADATA_KEY].decode("utf-8"))
            df = table.to_pandas()
        else:
            df = pd.read_csv(p)
        if prov is None:
            side = sidecar_path(p)
            prov = json.loads(side.read_text(encoding="utf-8")) if side.is_file() else {}
    except OSError as e:
        raise InputError(f"cannot read {p}: {e.strerror or e}") from None
    except (ValueError, UnicodeDecodeError) as e:     # JSONDecodeError, parser errors
        raise InputError(f"cannot read {p}: {' '.join(str(e).split())}") from None
    except Exception as e:   # noqa: BLE001 - pyarrow raises its own types for corrupt files
        if type(e).__module__.startswith("pyarrow"):
            raise InputError(f"cannot read {p}: {' '.join(str(e).split())}") from None
        raise
    return df, prov

