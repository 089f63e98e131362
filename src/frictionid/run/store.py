"""The run store: one SQLite file per run holding every evaluation, the iteration history and the result."""

import difflib
import functools
import io
import json
import sqlite3
import threading
from contextlib import contextmanager
from datetime import datetime, timezone
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ..errors import InputError

FILE_NAME = "store.sqlite"
SCHEMA_VERSION = "1"
_SCHEMA = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE evaluations (id INTEGER PRIMARY KEY, x_key TEXT NOT NULL, x BLOB NOT NULL, kind TEXT NOT NULL,
                          status TEXT NOT NULL, wall_time REAL NOT NULL, created TEXT NOT NULL);
CREATE INDEX evaluations_x ON evaluations (x_key);
CREATE TABLE outputs (evaluation INTEGER NOT NULL REFERENCES evaluations (id), name TEXT NOT NULL,
                      npy BLOB NOT NULL, PRIMARY KEY (evaluation, name));
CREATE TABLE iterations (iteration INTEGER PRIMARY KEY, x BLOB NOT NULL, objective REAL NOT NULL,
                         extra TEXT NOT NULL, created TEXT NOT NULL);
"""


def _locked(method):
    """One caller at a time on the store's connection (a transaction or a read with its fetches)."""
    @functools.wraps(method)
    def locked(self, *args, **kwargs):
        with self._lock:
            return method(self, *args, **kwargs)
    return locked


def _field_or_index(row: tuple, key):
    return getattr(row, key) if isinstance(key, str) else tuple.__getitem__(row, key)


class Evaluation(NamedTuple):
    """One recorded evaluation (``row.x`` or ``row["x"]``); ``index`` counts from 1, ``x`` is float64 (n_params,)."""
    index: int
    x: np.ndarray
    kind: str
    status: str
    wall_time: float
    created: str
    __getitem__ = _field_or_index


class Iteration(NamedTuple):
    """One optimiser iteration (``row.x`` or ``row["x"]``): ``x`` (n_params,), objective, JSON ``extra``."""
    iteration: int
    x: np.ndarray
    objective: float
    extra: dict
    created: str
    __getitem__ = _field_or_index


class RunStore:
    """Durable record of a run in ``<run_dir>/store.sqlite``.

    Every write is its own transaction, committed (WAL journal, ``synchronous=FULL``) before the method returns,
    so a process killed at any moment loses at most the evaluation it had not yet recorded. Open with :meth:`open`.
    Threads may share a store (the starts of a multi-start run): one statement or transaction at a time.
    """

    def __init__(self, connection: sqlite3.Connection, path: Path, resumed: bool):
        self._conn, self.path, self.resumed = connection, path, resumed
        self._lock = threading.RLock()

    @classmethod
    def open(cls, run_dir, config_text: str, fingerprint: str, resume: bool) -> "RunStore":
        """Create the store of a new run, or reopen an interrupted one.

        Parameters
        ----------
        run_dir : str or Path
            Run directory; created if missing.
        config_text : str
            The configuration as the user wrote it, kept to show what changed on a fingerprint mismatch.
        fingerprint : str
            Hash of everything that determines forward results (model, data, observables, solver options).
        resume : bool
            Continue the run in ``run_dir``; without a store there a new one is made (``resumed`` is False).

        Raises
        ------
        InputError
            A store exists and ``resume`` is False, its fingerprint differs, or it is not a readable store.
        """
        path = Path(run_dir) / FILE_NAME
        path.parent.mkdir(parents=True, exist_ok=True)
        conn = sqlite3.connect(path, timeout=10.0, isolation_level=None, check_same_thread=False)
        try:
            meta = _read_meta(conn, path)
            if meta is None:
                _create(conn, config_text, fingerprint)
                return cls(conn, path, resumed=False)
            if not resume:
                raise InputError(f"run directory {path.parent} already has a store; use --resume or another run.dir")
            if meta["fingerprint"] != fingerprint:
                raise _other_inputs(meta, config_text, fingerprint, path)
        except BaseException:
            conn.close()
            raise
        return cls(conn, path, resumed=True)

    def close(self) -> None:
        """Close the connection; everything is already committed."""
        self._conn.close()

    def __enter__(self) -> "RunStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @_locked
    def record(self, x, kind: str, outputs: dict, status: str = "ok", wall_time: float = 0.0) -> None:
        """Store one evaluation at coefficients ``x`` with its named output arrays (kept exactly, as .npy)."""
        x = _as_x(x)
        with _transaction(self._conn) as conn:
            row = conn.execute("INSERT INTO evaluations VALUES (NULL, ?, ?, ?, ?, ?, ?)",
                               (x.tobytes().hex(), x.tobytes(), kind, status, float(wall_time), _now()))
            conn.executemany("INSERT INTO outputs (evaluation, name, npy) VALUES (?, ?, ?)",
                             [(row.lastrowid, name, _to_npy(value)) for name, value in outputs.items()])

    @_locked
    def lookup(self, x, kind: str, status: str = "ok") -> dict | None:
        """Outputs of the latest evaluation of ``kind`` with ``status`` at bitwise the same ``x``, else None.

        A kind ``"a+b"`` also answers a lookup of ``"a"``: ``"forward+sensitivities"`` serves ``"forward"``.
        """
        rows = self._conn.execute("SELECT id, kind FROM evaluations WHERE x_key = ? AND status = ? "
                                  "ORDER BY id DESC", (_as_x(x).tobytes().hex(), status)).fetchall()
        for evaluation, stored_kind in rows:
            if stored_kind == kind or stored_kind.startswith(kind + "+"):
                outputs = self._conn.execute("SELECT name, npy FROM outputs WHERE evaluation = ?", (evaluation,))
                return {name: np.load(io.BytesIO(blob), allow_pickle=False) for name, blob in outputs}
        return None

    @_locked
    def n_evaluations(self, kind: str | None = None) -> int:
        """Number of recorded evaluations (any status), of exactly ``kind`` if given."""
        where, args = ("", ()) if kind is None else (" WHERE kind = ?", (kind,))
        return self._conn.execute("SELECT COUNT(*) FROM evaluations" + where, args).fetchone()[0]

    @_locked
    def evaluations(self) -> list[Evaluation]:
        """All evaluations in recording order (without their outputs; see :meth:`lookup`)."""
        rows = self._conn.execute("SELECT id, x, kind, status, wall_time, created FROM evaluations ORDER BY id")
        return [Evaluation(index, np.frombuffer(x, dtype="<f8").copy(), *rest) for index, x, *rest in rows]

    @_locked
    def record_iteration(self, iteration: int, x, objective: float, extra: dict | None = None) -> None:
        """Store an optimiser iteration; recording the same number again (a resumed replay) replaces it."""
        row = (int(iteration), _as_x(x).tobytes(), float(objective), json.dumps(extra or {}, default=_plain), _now())
        with _transaction(self._conn) as conn:
            conn.execute("INSERT OR REPLACE INTO iterations VALUES (?, ?, ?, ?, ?)", row)

    @_locked
    def iterations(self) -> list[Iteration]:
        """All iterations, by iteration number."""
        rows = self._conn.execute("SELECT * FROM iterations ORDER BY iteration").fetchall()
        return [Iteration(i, np.frombuffer(x, dtype="<f8").copy(), objective, json.loads(extra), created)
                for i, x, objective, extra, created in rows]

    def set_status(self, status: str, message: str = "") -> None:
        """Record the run's state, e.g. ``"running"``, ``"converged"``, ``"failed"`` with a message."""
        self._put_meta(status=status, message=message)

    def status(self) -> tuple[str, str]:
        """The run's state and message; ``("created", "")`` for a new store."""
        return self._get_meta("status"), self._get_meta("message")

    def put_result(self, result: dict) -> None:
        """Store the result (JSON-serialisable; numpy scalars and arrays are converted)."""
        self._put_meta(result=json.dumps(result, default=_plain))

    def result(self) -> dict | None:
        """The stored result, or None before :meth:`put_result`."""
        return json.loads(self._get_meta("result") or "null")

    @_locked
    def _put_meta(self, **values: str) -> None:
        with _transaction(self._conn) as conn:
            conn.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)", values.items())

    @_locked
    def _get_meta(self, key: str) -> str | None:
        return (self._conn.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone() or (None,))[0]


def _read_meta(conn: sqlite3.Connection, path: Path) -> dict | None:
    """The stored metadata, None for an empty file (a new store, or one killed before its creation committed)."""
    try:
        # WAL: readers never block the writer; FULL: a commit is on disk before record() returns.
        conn.executescript("PRAGMA journal_mode=WAL; PRAGMA synchronous=FULL;")
        tables = {name for (name,) in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        if not tables:
            return None
        if "meta" not in tables:
            raise InputError(f"{path}: not a frictionid run store (an SQLite file without its tables)")
        if (check := conn.execute("PRAGMA quick_check").fetchone()[0]) != "ok":
            raise InputError(f"{path}: not a readable frictionid run store (damaged: {check})")
        meta = dict(conn.execute("SELECT key, value FROM meta"))
    except sqlite3.DatabaseError as exc:
        raise InputError(f"{path}: not a readable frictionid run store ({exc})") from exc
    if meta.get("schema") != SCHEMA_VERSION:
        raise InputError(f"{path}: store schema {meta.get('schema')!r}, this frictionid reads {SCHEMA_VERSION!r}")
    return meta


def _create(conn: sqlite3.Connection, config_text: str, fingerprint: str) -> None:
    # One transaction: a kill during creation leaves an empty file, which counts as no store.
    meta = dict(schema=SCHEMA_VERSION, fingerprint=fingerprint, config_text=config_text, created=_now(),
                status="created", message="")
    with _transaction(conn):
        for statement in filter(str.strip, _SCHEMA.split(";")):
            conn.execute(statement)
        conn.executemany("INSERT INTO meta VALUES (?, ?)", meta.items())


@contextmanager
def _transaction(conn: sqlite3.Connection):
    """One write transaction, committed on leaving (the reason every write is durable when its call returns).

    A transaction still open on entry is one whose write was interrupted (Ctrl-C between its BEGIN and its COMMIT
    or ROLLBACK): that write never returned, so it is rolled back here and the new one starts clean."""
    if conn.in_transaction:
        conn.execute("ROLLBACK")
    try:
        conn.execute("BEGIN IMMEDIATE")
        yield conn
    except BaseException:
        if conn.in_transaction:
            conn.execute("ROLLBACK")
        raise
    conn.execute("COMMIT")


def _other_inputs(meta: dict, config_text: str, fingerprint: str, path: Path) -> InputError:
    """The error for resuming with inputs whose fingerprint differs, with the config lines that changed."""
    diff = list(difflib.unified_diff(meta["config_text"].splitlines(), config_text.splitlines(),
                                     "stored config", "given config", n=0, lineterm=""))
    what = ("the config differs:\n" + "\n".join(diff[:20] + ["..."] * (len(diff) > 20)) if diff else
            "the config text is the same, so a file it names (data, mesh) or a solver default changed")
    return InputError(f"{path} belongs to a run with other inputs (fingerprint {meta['fingerprint'][:12]} "
                      f"stored, {fingerprint[:12]} given); {what}\nRestore the inputs or use another run.dir.")


def _as_x(x) -> np.ndarray:
    return np.ascontiguousarray(x, dtype="<f8").reshape(-1)


def _to_npy(value) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, np.asarray(value), allow_pickle=False)
    return buffer.getvalue()


def _plain(obj):
    if isinstance(obj, (np.ndarray, np.generic)):
        return obj.tolist()
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _now() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")
