"""Where a sweep's rows live while it runs, and the table assembled from them.

Each finished run is appended to ``results/bench/<name>.rows.sqlite`` the moment its
row arrives, in its own transaction: a sweep that is interrupted, killed or crashes
keeps every finished row, and ``resume`` runs only the missing ones. SQLite (stdlib)
rather than one Parquet part per row: one file per sweep, atomic appends without
temporary-file bookkeeping, and rows of different columns (a failed run has a
traceback, a scored one has errors) stored as they are — each row is one JSON object,
whose floats round-trip exactly (``repr``), so a resumed table's old rows are
bit-identical to what the first run wrote. The table (``<name>.parquet``, ``.csv`` and
the ``.json`` provenance sidecar) is assembled from the store and written atomically
(temporary file, then ``os.replace``).

A sweep holds an exclusive lock (``<name>.lock``, ``flock``; released by the OS if the
process dies) for as long as it runs, so two sweeps never write one table; an existing
table is never replaced unless ``overwrite`` is asked for. Default names are unique
(scene, time stamp, random suffix).
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import re
import secrets
import sqlite3
import time
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np
import pandas as pd

from daebench.core.params import ParamError
from daebench.harness.files import atomic_write, ensure_writable_dir, results_dir, write_error
from daebench.harness.running import provenance

NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,127}")
OUTPUT_SUFFIXES = (".parquet", ".csv", ".json")


class StoreError(ParamError):
    """A table name, folder or lock that cannot be used; the message says what to do."""


def unique_name(scene_name: str) -> str:
    """<scene>-<UTC date-time>-<6 hex digits>: two sweeps never share a default name."""
    return f"{scene_name}-{time.strftime('%Y%m%d-%H%M%S', time.gmtime())}-{secrets.token_hex(3)}"


def check_name(name: str) -> str:
    """A table name is a plain file name; tables go to results/bench/."""
    if not isinstance(name, str) or not NAME_RE.fullmatch(name):
        raise StoreError(f"table name {name!r} must be a plain file name (letters, digits, '.', '_', '-'; "
                         f"no '/'), e.g. --name wp-beam; tables go to results/bench/ "
                         f"(set DAEBENCH_RESULTS to put results elsewhere)")
    return name


def _plain(x: Any) -> Any:
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, (np.ndarray,)):
        return x.tolist()
    return str(x)


def encode_row(row: dict[str, Any]) -> str:
    """One row as JSON; NaN/±inf kept (as JSON's NaN/Infinity tokens), floats exact."""
    return json.dumps(row, default=_plain, allow_nan=True)


class SweepStore:
    """The append-only row store and lock of one sweep table.

    Use :meth:`open`; it takes the lock and decides whether the sweep is new, resumed or
    replaces an old table. Rows are keyed by their ``run`` index in the plan.
    """

    def __init__(self, folder: Path, name: str, lock_fd: int) -> None:
        self.folder = folder
        self.name = name
        self._lock_fd = lock_fd
        self.db = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
        self.db.execute("CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
        self.db.execute("CREATE TABLE IF NOT EXISTS rows (run INTEGER PRIMARY KEY, row TEXT NOT NULL)")

    @property
    def path(self) -> Path:
        return self.folder / f"{self.name}.rows.sqlite"

    @property
    def table_path(self) -> Path:
        return self.folder / f"{self.name}.parquet"

    @classmethod
    def open(cls, folder: str | Path, name: str, manifest: dict[str, Any], resume: bool = False,
             overwrite: bool = False) -> "SweepStore":
        """Lock and open the store of table ``name`` under ``folder``.

        A new name starts a new store. An existing table or store is an error unless
        ``resume`` (its manifest — scene hash and plan — must equal ``manifest``) or
        ``overwrite`` (the old table and rows are deleted).

        Raises
        ------
        StoreError
        """
        check_name(name)
        folder = ensure_writable_dir(folder, "table folder")
        lock = folder / f"{name}.lock"
        made = not lock.exists()
        fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            raise StoreError(f"table '{name}' is being written by another sweep right now; wait for it, or "
                             f"choose another --name") from None
        try:
            store = cls._open_locked(folder, name, manifest, resume, overwrite, fd)
        except BaseException:
            if made:   # refused: the lock this call made goes with it
                lock.unlink(missing_ok=True)
            fcntl.flock(fd, fcntl.LOCK_UN)
            os.close(fd)
            raise
        store.new = not resume
        return store

    @classmethod
    def _open_locked(cls, folder: Path, name: str, manifest: dict[str, Any], resume: bool, overwrite: bool,
                     fd: int) -> "SweepStore":
        store_file = folder / f"{name}.rows.sqlite"
        existing = [p for p in [store_file] + [folder / f"{name}{s}" for s in OUTPUT_SUFFIXES] if p.exists()]
        if resume and overwrite:
            raise StoreError("give --resume or --overwrite, not both")
        if resume and not store_file.exists():
            raise StoreError(f"nothing to resume: no sweep named '{name}' in {folder} (its rows would be in "
                             f"{store_file.name}); run it without --resume")
        if existing and not (resume or overwrite):
            raise StoreError(f"table '{name}' already exists in {folder}; pass --resume to complete it, "
                             f"--overwrite to replace it, or choose another --name")
        if overwrite:
            for p in existing:
                p.unlink()
        if resume:
            check_store(store_file)
        try:
            store = cls(folder, name, fd)
            text = json.dumps(manifest, sort_keys=True, default=_plain)
            old = store.db.execute("SELECT value FROM meta WHERE key = 'manifest'").fetchone()
            if old is None:
                store.db.execute("INSERT INTO meta VALUES ('manifest', ?)", (text,))
        except sqlite3.Error as exc:
            raise write_error(exc, "the row store", store_file, "nothing has run yet") from None
        if old is not None and old[0] != text:
            store.db.close()
            raise StoreError(f"cannot resume '{name}': it was planned with other arguments (scene, integrators, "
                             f"grid, steps/tols, options or reference mode differ); repeat the original command "
                             f"with --resume, or start a new sweep")
        if resume:
            store.forget_lost_with_the_cluster()
        return store

    def forget_lost_with_the_cluster(self) -> list[int]:
        """Remove the rows of runs whose Dask worker was lost while they ran (``lost_worker``:
        the cluster failed, not the run), so that the resumed sweep runs them again; their
        run indices."""
        lost = [r for r, row in self.finished().items() if row.get("lost_worker")]
        for r in lost:
            self.db.execute("DELETE FROM rows WHERE run = ?", (r,))
        return lost

    def finished(self) -> dict[int, dict[str, Any]]:
        """The rows on disk, by run index."""
        return {int(r): json.loads(t) for r, t in self.db.execute("SELECT run, row FROM rows ORDER BY run")}

    def append(self, row: dict[str, Any]) -> None:
        """Write one finished row (its own transaction: on disk when this returns).

        Raises
        ------
        OutputWriteError
            When the row cannot be stored (full disk); the rows stored before it are kept.
        """
        try:
            self.db.execute("INSERT OR REPLACE INTO rows VALUES (?, ?)", (int(row["run"]), encode_row(row)))
        except sqlite3.Error as exc:
            n = self.db.execute("SELECT COUNT(*) FROM rows").fetchone()[0]
            raise write_error(
                exc, f"the row of run {row['run']} to", self.path,
                f"the {n} rows stored before it are kept there; free space and complete the sweep with "
                f"--resume --name {self.name} (the runs without a row are run then)") from None

    new = False   # opened for a new sweep (not resumed): discard() may remove it

    def close(self) -> None:
        """Close the database and release the lock."""
        try:
            self.db.close()
        finally:
            if self._lock_fd >= 0:
                fcntl.flock(self._lock_fd, fcntl.LOCK_UN)
                os.close(self._lock_fd)
                self._lock_fd = -1

    def discard(self) -> None:
        """Remove a store that was made for a sweep refused before any run (its rows file and
        lock; the lock file is removed while still held, then released), so that nothing
        is left behind and the corrected command starts afresh."""
        rows = self.db.execute("SELECT COUNT(*) FROM rows").fetchone()[0]
        self.db.close()
        try:
            if rows == 0:
                for p in (self.path, self.path.with_name(self.path.name + "-journal"),
                          self.folder / f"{self.name}.lock"):
                    try:
                        p.unlink()
                    except FileNotFoundError:
                        pass
        finally:
            if self._lock_fd >= 0:
                fcntl.flock(self._lock_fd, fcntl.LOCK_UN)
                os.close(self._lock_fd)
                self._lock_fd = -1

    def __enter__(self) -> "SweepStore":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def check_store(path: Path) -> None:
    """Refuse to resume from a row store that is empty or damaged (truncated, a flipped
    byte, a row that is not JSON): resuming would silently run the whole sweep again or
    mix damaged rows into the table.

    Raises
    ------
    StoreError
        Naming the file, what is wrong and the fix.
    """
    fix = (f"move it away and run the sweep again with --overwrite (its finished rows are lost), or restore "
           f"the file from a copy")
    size = path.stat().st_size
    if size == 0:
        raise StoreError(f"cannot resume: the row store {path} is empty (0 bytes; a sweep's store holds at least "
                         f"its plan): it is damaged; {fix}")
    try:
        db = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=30.0)
        try:
            check = db.execute("PRAGMA integrity_check").fetchall()
            if check != [("ok",)]:
                raise sqlite3.DatabaseError("; ".join(str(c[0]) for c in check[:3]))
            tables = {r[0] for r in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
            if not {"meta", "rows"} <= tables or db.execute(
                    "SELECT value FROM meta WHERE key = 'manifest'").fetchone() is None:
                raise sqlite3.DatabaseError("it has no plan (not a daebench row store)")
            for run, text in db.execute("SELECT run, row FROM rows"):
                try:
                    row = json.loads(text)
                except (TypeError, ValueError):
                    raise sqlite3.DatabaseError(f"the row of run {run} is not JSON") from None
                if not isinstance(row, dict) or row.get("run") != run:
                    raise sqlite3.DatabaseError(f"the row of run {run} is not a row of this sweep")
        finally:
            db.close()
    except sqlite3.Error as exc:
        raise StoreError(f"cannot resume: the row store {path} is damaged ({exc}); {fix}") from None


def assemble(rows: Iterable[dict[str, Any]]) -> pd.DataFrame:
    """The table: one row per run, in plan order (columns in first-appearance order of
    that order, so a table does not depend on which run finished first)."""
    ordered = sorted(rows, key=lambda r: int(r["run"]))
    return pd.DataFrame(ordered) if ordered else pd.DataFrame({"run": pd.Series([], dtype="int64")})


def write_table(df: pd.DataFrame, name: str, scenes: Iterable[Any] = (), folder: Path | None = None,
                kept: str = "", **extra: Any) -> Path:
    """<folder>/<name>.parquet + .csv + .json (provenance), each written atomically;
    returns the parquet path. ``folder`` defaults to results/bench.

    Raises
    ------
    OutputWriteError
        When a file cannot be written (full disk); no temporary file is left, and the
        message says ``kept`` (where the rows are safe).
    """
    out = ensure_writable_dir(Path(folder) if folder is not None else results_dir() / "bench", "table folder")
    path = out / f"{name}.parquet"
    if not kept and (out / f"{name}.rows.sqlite").exists():
        kept = (f"every finished row is kept in {out / name}.rows.sqlite: the same command with --resume --name {name} "
                f"writes the table without running anything again")
    atomic_write(path, lambda p: df.to_parquet(p, index=False), "the table", kept)
    atomic_write(path.with_suffix(".csv"), lambda p: df.to_csv(p, index=False), "the table", kept)
    hashes = sorted(set(df["scene_hash"].dropna())) if "scene_hash" in df else []
    pairs = [(s.name, s.hash) for s in scenes] + [(str(df["case"].iloc[0]), h) for h in hashes if len(df)]
    prov = provenance.collect(list(dict.fromkeys(pairs)))
    atomic_write(path.with_suffix(".json"), lambda p: provenance.write_sidecar(p, prov, rows=len(df), **extra),
                 "the table's sidecar", kept)
    return path


class TableError(ParamError):
    """A sweep table that cannot be read; the message names the file and what is wrong."""


def read_table(path: str | Path) -> pd.DataFrame:
    """A sweep table from .parquet or .csv.

    Raises
    ------
    TableError
        For a missing file, a folder, an unknown suffix or a damaged file.
    """
    p = Path(path)
    if not p.exists():
        raise TableError(f"table '{p}' does not exist (sweeps write results/bench/<name>.parquet)")
    if p.is_dir():
        raise TableError(f"'{p}' is a folder; give a table file, e.g. {p}/<name>.parquet")
    if p.suffix not in (".parquet", ".csv"):
        raise TableError(f"'{p}' is not a sweep table (.parquet or .csv)")
    try:
        return pd.read_parquet(p) if p.suffix == ".parquet" else pd.read_csv(p)
    except Exception as exc:  # pyarrow and the csv parser raise many types for a damaged file
        raise TableError(f"cannot read table '{p}': {type(exc).__name__}: {str(exc)[:200]} "
                         f"(truncated or not written by daebench?)") from None


def interrupted_rows(specs: Sequence[Any], done: set[int], scene: Any, reason: str) -> list[dict[str, Any]]:
    """A row for every planned run without a finished row (status 'interrupted'); such rows
    are not stored, so ``resume`` runs them."""
    out = []
    for s in specs:
        if s.index not in done:
            out.append({"run": s.index, "case": scene.name, "integrator": s.integrator, "label": s.label,
                        **s.varied, "settings": json.dumps(s.options, sort_keys=True, default=str),
                        "status": "interrupted", "message": reason, "verdict": "interrupted",
                        "verdict_reason": reason, "wall_s": math.nan})
    return out
