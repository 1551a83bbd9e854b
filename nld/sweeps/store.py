"""The resumable per-point result store of a sweep: one parquet file per finished point.

    from nld.sweeps.store import ResultStore
    store = ResultStore("maps/run1")
    store.prepare(provenance, settings=("param", "values", "rtol"), resume=True)
    done = store.finished()                   # {(group, index): record} already on disk
    store.write(record)                       # atomically, as each point finishes
    records = store.records()                 # every finished point, in file-name order

A *record* is a dict with ``"direction"`` (the point's group: a sweep direction "up"/"down", or
"grid"), ``"index"`` (int), ``"table"`` (a DataFrame: the point's rows) and any JSON-able
metadata (value, status, message, final state, wall time ...). :meth:`ResultStore.write` stores
it as ``DIR/point-<group>-<index:05d>.parquet``: the table, with the metadata as JSON in the
Arrow schema metadata under :data:`META_KEY`. It writes a temporary file and renames it, so a
killed process leaves either the whole point file or none (the points in progress run again on
resume).

``DIR/provenance.json`` describes the whole sweep (nld version, git hash, scene and settings).
:meth:`ResultStore.prepare` creates the directory and checks it against the new provenance: the
named settings must match those of a sweep already there (``resume=True``, or finished points
present), else a one-line :class:`nld.errors.InputError` names the first field that differs; a
directory with finished points is refused without ``resume``. It then (re)writes provenance.json.
"""
from __future__ import annotations

import json
from pathlib import Path


from nld.errors import InputError, OutputError
from nld.output.io import json_default, write_atomic  # noqa: F401 (json_default re-exported)

__all__ = ["ResultStore", "PROVENANCE", "META_KEY", "read_point", "json_default"]

PROVENANCE = "provenance.json"
META_KEY = b"nld_point"
PATTERN = "point-*.parquet"



def _plain(value) -> str:
    """Canonical JSON text of a setting (for comparing an old and a new provenance)."""
    return json.dumps(json.loads(json.dumps(value, default=json_default)), sort_keys=True)



def read_point(path) -> dict:
    """The record stored in one point file (its metadata and ``"table"``)."""
    import pyarrow.parquet as pq
    t = pq.read_table(path)
    meta = json.loads((t.schema.metadata or {}).get(META_KEY, b"{}").decode())
    meta["table"] = t.to_pandas()
    return meta


# what produced a sweep directory -> the command that makes it, for the messages
_LABELS = {"bifurcation": "nld bifurcation", "chaos_map": "nld chaos-map",
           "census sweep": "nld attractors --param (a census sweep)"}
_COMMANDS = {"bifurcation": "bifurcation", "chaos-map": "chaos_map", "attractors": "census sweep"}


def producer(provenance: dict, what: str | None = None) -> str | None:
    """What made (or makes) a sweep directory: its provenance's ``producer``, or its ``kind``
    when that is one of nld's sweeps ("bifurcation", "chaos_map"), else the command of its
    ``command`` line ("nld attractors ..." -> "census sweep"), else ``what`` when it names a kind
    of sweep; None when unknown (then only the settings are compared)."""
    if provenance.get("producer"):
        return str(provenance["producer"])
    if provenance.get("kind") in _LABELS:
        return str(provenance["kind"])
    words = str(provenance.get("command") or "").split()
    if len(words) >= 2 and words[1] in _COMMANDS:
        return _COMMANDS[words[1]]
    return what if what not in (None, "sweep", "run") else None


def _reason(e: OSError) -> str:
    """The words of a disk error: 'No space left on device', 'Permission denied' ..."""
    import os
    if e.errno:
        return os.strerror(e.errno)
    return " ".join(str(e).split())[:160]


class ResultStore:
    """The point files and provenance.json of one output directory (module docstring)."""

    def __init__(self, out):
        self.path = Path(out).expanduser()

    def __repr__(self) -> str:
        return f"ResultStore({str(self.path)!r})"

    @classmethod
    def existing(cls, out, what: str = "sweep") -> "ResultStore":
        """The store of a directory that must exist (InputError ``<what> directory not found``)."""
        store = cls(out)
        if not store.path.is_dir():
            raise InputError(f"{what} directory not found: {store.path}")
        return store

    # ---- provenance and settings

    @property
    def provenance_path(self) -> Path:
        return self.path / PROVENANCE

    def provenance(self) -> dict:
        """provenance.json as a dict ({} when there is none)."""
        pp = self.provenance_path
        if not pp.is_file():
            return {}
        try:
            return json.loads(pp.read_text())
        except ValueError as e:
            raise InputError(f"out = {str(self.path)!r}: {PROVENANCE} cannot be read ({e})") from None

    def check_settings(self, provenance: dict, settings, *, what: str = "sweep",
                       defaults: dict | None = None) -> None:
        """InputError naming the first of ``settings`` whose value in ``provenance`` differs from
        provenance.json's (nothing when there is no provenance.json), or saying that the
        directory holds another command's output (:func:`producer`). ``defaults``: the value an
        older provenance.json that lacks a setting stands for."""
        if not self.provenance_path.is_file():
            return
        old = self.provenance()
        mine, theirs = producer(provenance, what), producer(old)
        if theirs is not None and mine is not None and theirs != mine:
            raise InputError(f"out = {str(self.path)!r} holds the output of another command "
                             f"({_LABELS.get(theirs, theirs)}), not of {_LABELS.get(mine, mine)}: "
                             "use another directory")
        defaults = defaults or {}
        for k in settings:
            if _plain(old.get(k, defaults.get(k))) != _plain(provenance.get(k)):
                raise InputError(f"out = {str(self.path)!r} holds a different {what} ({k} differs): "
                                 "use another directory, or the same settings to resume")

    def prepare(self, provenance: dict, settings, *, resume: bool, what: str = "sweep") -> None:
        """Create the directory, check it (module docstring) and write provenance.json."""
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise InputError(f"out = {str(self.path)!r}: cannot create the directory "
                             f"({e.strerror or e})") from None
        n = self.count()
        if resume or n:
            self.check_settings(provenance, settings, what=what)
        if n and not resume:
            raise InputError(f"out = {str(self.path)!r} already holds {n} finished points: pass "
                             "resume=True (--resume) to continue that sweep, or use another directory")
        made_by = producer(provenance, what)
        if made_by is not None and "producer" not in provenance and \
                provenance.get("kind") not in _LABELS:
            provenance = {**provenance, "producer": made_by}
        text = json.dumps(provenance, indent=2, default=json_default) + "\n"
        try:
            write_atomic(self.provenance_path, lambda tmp: tmp.write_text(text))
        except OSError as e:
            raise OutputError(f"cannot write {self.provenance_path}: {_reason(e)}") from None

    # ---- points

    def point_path(self, group: str, index: int) -> Path:
        return self.path / f"point-{group}-{int(index):05d}.parquet"

    def write(self, record: dict) -> Path:
        """Write one finished point atomically; returns its path."""
        import pyarrow as pa
        import pyarrow.parquet as pq
        path = self.point_path(record["direction"], record["index"])
        table = pa.Table.from_pandas(record["table"], preserve_index=False)
        meta = {k: v for k, v in record.items() if k != "table"}
        md = dict(table.schema.metadata or {})
        md[META_KEY] = json.dumps(meta, default=json_default).encode()
        table = table.replace_schema_metadata(md)
        try:
            return write_atomic(path, lambda tmp: pq.write_table(table, tmp))
        except OSError as e:
            raise OutputError(f"cannot write the point file {path}: {_reason(e)}; the points "
                              f"finished before it are kept in {self.path} (run the same command "
                              "with --resume, resume=True, once it can be written)") from None

    def files(self, group: str | None = None) -> list[Path]:
        """The finished point files (of one group), sorted by name."""
        pattern = PATTERN if group is None else f"point-{group}-*.parquet"
        return sorted(self.path.glob(pattern)) if self.path.is_dir() else []

    def count(self) -> int:
        return len(self.files())

    def records(self, group: str | None = None) -> list[dict]:
        """Every finished point (of one group) as a record, in file-name order; a file that
        cannot be read (cut short, corrupt) -> InputError naming it and saying how to recompute
        it."""
        out = []
        for p in self.files(group):
            try:
                out.append(read_point(p))
            except Exception as e:    # noqa: BLE001 - pyarrow, JSON and OS errors alike
                raise InputError(f"point file {p} cannot be read ({type(e).__name__}: "
                                 f"{' '.join(str(e).split())[:160]}); delete it and run the same "
                                 "command with --resume (resume=True) to compute that point "
                                 "again") from None
        return out

    def finished(self, group: str | None = None) -> dict:
        """{(group, index): record} of the finished points, for resume; a file that cannot be
        read is left out (its point runs again)."""
        done = {}
        for p in self.files(group):
            try:
                rec = read_point(p)
            except Exception:         # noqa: BLE001 - an unreadable file: run the point again
                continue
            done[(rec["direction"], int(rec["index"]))] = rec
        return done
