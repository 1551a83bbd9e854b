"""Result tables on disk, with their provenance.

Two formats, chosen by the file suffix:

* ``.parquet``: the provenance is stored as JSON in the Arrow schema metadata under the key
  ``b"nld"``; a sidecar ``PATH.json`` with the same JSON is written too, for human reading.
* ``.csv``: the provenance is stored in the sidecar ``PATH.json`` (e.g. ``run.csv.json``).

Any other suffix -> :class:`~nld.errors.InputError` naming the allowed ones.

The one writer of nld's output files (tables, their sidecars, sweep points, study outputs,
figures, reports): :func:`write_atomic` writes a temporary file in the target's directory and
renames it over the target only when the whole file was written, so a reader (or a later run)
sees the old file or the new one, never a mixture; :func:`write_all` does the same for several
files that belong together (a table and its sidecar: nothing is replaced unless every one was
written). A failed or interrupted run does not replace its target at all: its partial result
goes beside it, to :func:`partial_path` (``run.csv`` -> ``run.partial.csv``), marked
``"partial": true`` in its provenance (``save_table(..., partial=True)``). A file that cannot be
written -> InputError naming that file (the sidecar when it is the sidecar that failed).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd

from nld.errors import InputError

__all__ = ["SUFFIXES", "METADATA_KEY", "check_table_path", "sidecar_path", "partial_path", "save_table",
           "load_table", "provenance_json", "write_atomic", "write_all", "save_figure",
           "FIGURE_SUFFIXES", "check_figure_path"]

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


def partial_path(path) -> Path:
    """Where the partial result of a failed or interrupted run goes instead of ``path``:
    ``run.csv`` -> ``run.partial.csv`` (beside it, same suffix)."""
    p = Path(path)
    return p.with_name(f"{p.stem}.partial{p.suffix}")


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


def _tmp_path(path: Path) -> Path:
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def remove_temporary(folder, pids) -> int:
    """Remove the temporary files that processes ``pids`` left in ``folder`` (a worker killed
    while it wrote a file, :func:`write_atomic`); returns how many were removed."""
    n = 0
    for pid in pids:
        for tmp in Path(folder).glob(f".*.{int(pid)}.tmp"):
            try:
                tmp.unlink()
                n += 1
            except OSError:
                pass
    return n


def _cannot_write(path: Path, e: OSError, note: str = "") -> InputError:
    return InputError(f"cannot write {path}: {e.strerror or e}{note}")


def write_atomic(path, write) -> Path:
    """``write(tmp)`` then rename tmp to ``path``: readers see the whole file or none, and an
    existing ``path`` is replaced only by a file written to its end (a failed ``write`` leaves it
    as it was and removes tmp). Raises what ``write`` raises (OSError for the disk's errors)."""
    path = Path(path)
    tmp = _tmp_path(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def write_all(files, note_after: str = "") -> list[Path]:
    """Write several files that belong together: ``files`` is a list of ``(path, write)``; every
    ``write(tmp)`` runs first, and only when all of them succeeded are the files renamed into
    place (nothing is replaced otherwise; the temporary files are removed). A failure ->
    InputError naming the file whose writing failed, and saying that nothing was replaced."""
    done = []
    try:
        for path, write in files:
            path = Path(path)
            tmp = _tmp_path(path)
            done.append((path, tmp))
            try:
                write(tmp)
            except OSError as e:
                others = [str(p) for p, _ in files if Path(p) != path]
                kept = (f"; nothing replaced ({', '.join([str(path)] + others)} unchanged)"
                        if others else "; the file is unchanged")
                raise _cannot_write(path, e, kept) from None
        for path, tmp in done:
            try:
                os.replace(tmp, path)
            except OSError as e:
                raise _cannot_write(path, e) from None
    finally:
        for _, tmp in done:
            if tmp.exists():
                try:
                    tmp.unlink()
                except OSError:
                    pass
    return [p for p, _ in done]


def _write_text(path: Path, text: str) -> None:
    path.write_text(text, encoding="utf-8")


def save_table(df: pd.DataFrame, path, provenance: dict | None, *, partial: bool = False) -> Path:
    """Write ``df`` to ``path`` (``.parquet`` or ``.csv``) with its provenance; returns the path
    written.

    partial: the result of a failed or interrupted run: written to :func:`partial_path` (``path``
    itself is left alone) with ``"partial": true`` in its provenance. The table and its sidecar are
    written together (:func:`write_all`: both or neither replaced). Missing parent directories are
    created. An unsupported suffix or a file that cannot be written -> InputError (one line
    naming the file that failed).
    """
    p = check_table_path(path)
    if partial:
        p = partial_path(p)
        provenance = dict(provenance or {}, partial=True)
    text = provenance_json(provenance)
    pretty = provenance_json(provenance, indent=2) + "\n"
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"cannot write {p}: cannot create its directory ({e.strerror or e})") from None
    if p.suffix.lower() == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq
        table = pa.Table.from_pandas(df, preserve_index=False)
        meta = dict(table.schema.metadata or {})
        meta[METADATA_KEY] = text.encode("utf-8")
        table = table.replace_schema_metadata(meta)

        def write_table(tmp):
            pq.write_table(table, tmp)
    else:
        def write_table(tmp):
            df.to_csv(tmp, index=False)
    write_all([(p, write_table), (sidecar_path(p), lambda tmp: _write_text(tmp, pretty))])
    return p


FIGURE_SUFFIXES = (".png", ".pdf", ".svg")


def check_figure_path(path, option: str = "--plot") -> Path:
    """The path of a figure to write, checked before a long run: a .png, .pdf or .svg file whose
    directory exists or can be created and is writable; else InputError naming ``option``."""
    p = Path(path).expanduser()
    if p.suffix.lower() not in FIGURE_SUFFIXES:
        raise InputError(f"{option} = {str(path)!r}: give a .png, .pdf or .svg file")
    if p.is_dir():
        raise InputError(f"{option} = {str(path)!r}: is a directory; give a file name")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        why = "a file is in the way" if isinstance(e, (FileExistsError, NotADirectoryError)) \
            else (e.strerror or str(e))
        raise InputError(f"{option} = {str(path)!r}: cannot create its directory {p.parent} "
                         f"({why})") from None
    if not os.access(p.parent, os.W_OK):
        raise InputError(f"{option} = {str(path)!r}: its directory {p.parent} is not writable")
    return p


def save_figure(fig, path, **kw) -> Path:
    """``fig.savefig`` to ``path`` (its suffix gives the format) through :func:`write_atomic`;
    a file that cannot be written -> InputError naming it. ``kw``: more arguments of savefig."""
    p = Path(path).expanduser()
    fmt = p.suffix.lower().lstrip(".") or None
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(p, lambda tmp: fig.savefig(tmp, format=fmt, **kw))
    except OSError as e:
        raise _cannot_write(p, e) from None
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

