"""The results store: one SQLite file that every CLI check, batch job and service request is
recorded in, and that the nightly report reads.

Safe under concurrent writers (service workers and a batch at once): WAL journal, a busy
timeout, and one short transaction per record. The schema is versioned with PRAGMA user_version
and migrated forward on open; a file that is locked, corrupt, from a newer pathcheck or not a
pathcheck store gets a PathcheckError and is never overwritten.

Times are UTC seconds since the epoch; lengths in mm, as in the results document."""

from __future__ import annotations

import io
import sqlite3
import threading
import time
import zlib
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np

from checker.config import default_config
from checker.errors import PathcheckError
from checker.results import VERDICTS, ResultsDocument, stock_line

JobStatus = Literal["ok", "findings", "failed"]
JOB_STATUSES: tuple[str, ...] = ("ok", "findings", "failed")

# migrations[i] takes a store from user_version i to i + 1; never edit one that has shipped
MIGRATIONS: tuple[str, ...] = (
    """
    CREATE TABLE jobs (
        id INTEGER PRIMARY KEY,
        recorded_at REAL NOT NULL,
        source TEXT NOT NULL,
        status TEXT NOT NULL CHECK (status IN ('ok', 'findings', 'failed')),
        error TEXT,
        job_path TEXT NOT NULL,
        part TEXT,
        part_hash TEXT,
        cutter TEXT,
        machine TEXT,
        axis_class TEXT,
        points INTEGER,
        n_ok INTEGER, n_gouge INTEGER, n_interference INTEGER, n_holder INTEGER,
        n_inaccessible INTEGER,
        worst_margin REAL,
        worst_depth REAL,
        largest_safe_cutter REAL,
        largest_safe_standard TEXT,
        elapsed_s REAL NOT NULL,
        document BLOB
    );
    CREATE INDEX jobs_recorded_at ON jobs (recorded_at);
    CREATE TABLE requests (
        id INTEGER PRIMARY KEY,
        recorded_at REAL NOT NULL,
        op TEXT NOT NULL,
        ok INTEGER NOT NULL,
        elapsed_s REAL NOT NULL,
        error TEXT,
        job_id INTEGER REFERENCES jobs (id)
    );
    CREATE INDEX requests_recorded_at ON requests (recorded_at);
    """,
    """
    ALTER TABLE jobs ADD COLUMN arrays BLOB;
    ALTER TABLE jobs ADD COLUMN cutter_size REAL;
    ALTER TABLE jobs ADD COLUMN cutter_kind TEXT;
    CREATE INDEX jobs_path ON jobs (job_path, recorded_at);
    """,
    """
    ALTER TABLE jobs ADD COLUMN n_within_tolerance INTEGER;
    ALTER TABLE jobs ADD COLUMN n_crash INTEGER;
    """,
    """
    ALTER TABLE jobs ADD COLUMN stock TEXT;
    """,
    """
    ALTER TABLE jobs ADD COLUMN n_machine INTEGER;
    """,
)
SCHEMA_VERSION = len(MIGRATIONS)

# per-point columns kept beside the document so the report never has to parse JSON
VERDICT_CODE = {v: i for i, v in enumerate(VERDICTS)}
ARRAY_FIELDS = ("cc", "allowable", "verdict", "depth", "b_best", "b_chosen", "surface", "kind")
# kept since the report tells unbounded from not computed; rows recorded before: = kind
LATER_ARRAY_FIELDS = ("contact",)


@dataclass(frozen=True)
class JobRow:
    """One recorded job as the report sees it (no document)."""

    id: int
    recorded_at: float
    source: str
    status: str
    error: str | None
    job_path: str
    part: str | None
    part_hash: str | None
    cutter: str | None
    machine: str | None
    axis_class: str | None
    points: int | None
    n_ok: int | None
    n_gouge: int | None
    n_interference: int | None
    n_holder: int | None
    n_inaccessible: int | None
    n_within_tolerance: int | None
    n_crash: int | None
    worst_margin: float | None
    worst_depth: float | None
    largest_safe_cutter: float | None
    largest_safe_standard: str | None
    elapsed_s: float
    cutter_size: float | None
    cutter_kind: str | None
    stock: str | None = None  # the stock and fixtures line (`checker.results.stock_line`)
    n_machine: int | None = None  # poses and moves closer to the machine than its clearance


_ROW_COLUMNS = ", ".join(JobRow.__dataclass_fields__)


@dataclass(frozen=True)
class Pruned:
    """What `prune` deleted: jobs and service requests, and the jobs left."""

    jobs: int
    requests: int
    remaining: int


def point_arrays(doc: ResultsDocument) -> dict[str, np.ndarray]:
    """Per-point arrays of a document: cc (N,3) mm (the contact, else the deepest point, else the
    tip), allowable/depth/b_best/b_chosen (the B written) (N,) with nan for null, verdict (N,)
    int8 code into VERDICTS, surface (N,) int32 (-1 null), kind (N,) bool (True for a pose at a
    CL record, False for a cycle or move pose), contact (N,) bool (a cutting pose with a
    contact point: there a nan allowable is unbounded)."""
    pts = doc.points

    def col(name: str) -> np.ndarray:
        return np.array([getattr(p, name) for p in pts], dtype=float).reshape(len(pts))

    return {
        "cc": np.array([p.cc or p.point or p.tip for p in pts], dtype=float).reshape(len(pts), 3),
        "allowable": col("allowable"),
        "verdict": np.array([VERDICT_CODE[p.verdict] for p in pts], dtype=np.int8),
        "depth": col("depth"),
        "b_best": col("b_best"),
        "b_chosen": col("b"),
        "surface": np.array(
            [-1 if (p.cc_surface if p.cc_surface is not None else p.surface) is None
             else (p.cc_surface if p.cc_surface is not None else p.surface) for p in pts],
            dtype=np.int32
        ),
        "kind": np.array([p.kind == "cl" for p in pts], dtype=bool),
        "contact": np.array([p.kind == "cl" and p.cc is not None for p in pts], dtype=bool),
    }


def _pack_arrays(arrays: dict[str, np.ndarray]) -> bytes:
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return zlib.compress(buf.getvalue(), 1)


def _unpack_arrays(blob: bytes) -> dict[str, np.ndarray]:
    """The arrays of `_pack_arrays`; ValueError when the blob is not that (damaged)."""
    try:
        with np.load(io.BytesIO(zlib.decompress(blob)), allow_pickle=False) as data:
            out = {k: data[k] for k in ARRAY_FIELDS}
            for k in LATER_ARRAY_FIELDS:
                out[k] = data[k] if k in data.files else out["kind"].copy()
    except (zlib.error, OSError, EOFError, KeyError, ValueError, TypeError) as err:
        raise ValueError(f"{type(err).__name__}: {err}") from err
    n = len(out["verdict"])
    if out["cc"].shape != (n, 3) or any(len(v) != n for v in out.values()):
        raise ValueError("per-point arrays of different lengths")
    return out


def job_status(doc: ResultsDocument) -> JobStatus:
    """The document's own status ('ok' or 'findings'; `checker.verdict.status`)."""
    return doc.summary.status




class ResultsStore:
    """An open results store. Use as a context manager or call `close()`."""

    def __init__(
        self, path: str | Path | None = None, *, busy_timeout_s: float | None = None
    ) -> None:
        """Open (and create or migrate) the store at `path`, default: the config's store path
        (PATHCHECK_STORE overrides); writers wait up to `busy_timeout_s` for a lock."""
        cfg = default_config().store
        self.path = Path(path) if path is not None else cfg.resolved_path()
        self.busy_timeout_s = cfg.busy_timeout_s if busy_timeout_s is None else busy_timeout_s
        self._lock = threading.RLock()  # one connection, shared safely by a process's threads
        if self.path.is_dir():
            raise PathcheckError(
                "expected an SQLite results store file, found a directory", path=self.path,
                code="store",
            )
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise PathcheckError(
                f"cannot create the store's folder: {err.strerror}", path=self.path, code="store"
            ) from err
        self._con = self._connect()
        try:
            self._migrate()
        except BaseException:
            self._con.close()
            raise

    # ------------------------------------------------------------------ opening
    def _fail(self, err: sqlite3.Error, doing: str) -> PathcheckError:
        text = str(err)
        if "locked" in text or "busy" in text:
            msg = (
                f"store is locked by another process (waited {self.busy_timeout_s:g} s) "
                f"while {doing}"
            )
        elif not isinstance(err, sqlite3.OperationalError):
            msg = (
                f"expected an SQLite pathcheck store, found an unreadable file ({text}) "
                f"while {doing}; the file was left untouched"
            )
        else:
            msg = f"store error while {doing}: {text}"
        return PathcheckError(msg, path=self.path, code="store")

    def _connect(self) -> sqlite3.Connection:
        """Connect, check the file is a pathcheck store this version understands (read only),
        and only then switch it to WAL: a file that fails the check is not written at all."""
        try:
            con = sqlite3.connect(
                self.path, timeout=self.busy_timeout_s, isolation_level=None,
                check_same_thread=False,
            )
        except sqlite3.Error as err:
            raise self._fail(err, "opening the store") from err
        try:
            con.execute(f"PRAGMA busy_timeout = {int(self.busy_timeout_s * 1000)}")
            self._check(con)
            con.execute("PRAGMA foreign_keys = ON")
            mode = self._switch_to_wal(con)
            if mode.lower() != "wal":
                raise PathcheckError(
                    f"expected the store to switch to WAL journal mode, found '{mode}'",
                    path=self.path, code="store",
                )
        except sqlite3.Error as err:
            con.close()
            raise self._fail(err, "opening the store") from err
        except PathcheckError:
            con.close()
            raise
        return con

    def _switch_to_wal(self, con: sqlite3.Connection) -> str:
        """`PRAGMA journal_mode = WAL`, retried until the busy timeout: on a new file, openers
        that both hold a shared lock and both want the exclusive one get SQLITE_BUSY at once
        (SQLite's deadlock rule skips the busy handler), so the wait is ours."""
        deadline = time.monotonic() + self.busy_timeout_s
        while True:
            try:
                return con.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            except sqlite3.OperationalError as err:
                if "locked" not in str(err) or time.monotonic() >= deadline:
                    raise
                time.sleep(0.02)

    def _check(self, con: sqlite3.Connection) -> int:
        """The schema version of the file; PathcheckError for a newer one or a foreign file."""
        # one statement, one snapshot: read apart, another opener's migration could commit
        # between the two and show tables at version 0 (a "foreign" file)
        version, tables = con.execute(
            "SELECT (SELECT user_version FROM pragma_user_version), "
            "(SELECT count(*) FROM sqlite_master WHERE name NOT LIKE 'sqlite_%')").fetchone()
        if version > SCHEMA_VERSION:
            raise PathcheckError(
                f"store schema version {version} is newer than this pathcheck understands "
                f"(expected at most {SCHEMA_VERSION}); upgrade pathcheck; the file was left "
                "untouched", path=self.path, code="store",
            )
        if version == 0 and tables:
            raise PathcheckError(
                f"expected a pathcheck results store, found an SQLite file with {tables} other "
                "tables; the file was left untouched", path=self.path, code="store",
            )
        return version

    @contextmanager
    def _write(self, doing: str) -> Iterator[sqlite3.Connection]:
        """One short write transaction (BEGIN IMMEDIATE waits up to the busy timeout)."""
        with self._lock:
            try:
                self._con.execute("BEGIN IMMEDIATE")
            except sqlite3.Error as err:
                raise self._fail(err, doing) from err
            try:
                yield self._con
                self._con.execute("COMMIT")
            except BaseException as err:
                self._rollback()
                if isinstance(err, sqlite3.Error):
                    raise self._fail(err, doing) from err
                raise

    def _rollback(self) -> None:
        """End a failed transaction. SQLite has already rolled back after some errors (a full
        disk, an I/O error): then there is nothing to end, and that is not a second error."""
        if self._con.in_transaction:
            with suppress(sqlite3.Error):  # the first error is the one worth reporting
                self._con.execute("ROLLBACK")

    def _migrate(self) -> None:
        """Apply the migrations above the file's version, in one transaction."""
        if self.schema_version == SCHEMA_VERSION:
            return
        with self._write("migrating the schema") as con:
            version = self._check(con)  # again, inside the lock: another writer may have won
            for step in range(version, SCHEMA_VERSION):
                for statement in MIGRATIONS[step].split(";"):
                    if statement.strip():
                        con.execute(statement)
                con.execute(f"PRAGMA user_version = {step + 1}")

    @property
    def schema_version(self) -> int:
        try:
            return self._con.execute("PRAGMA user_version").fetchone()[0]
        except sqlite3.Error as err:
            raise self._fail(err, "reading the schema version") from err

    def close(self) -> None:
        self._con.close()

    def __enter__(self) -> ResultsStore:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ writing
    def record_job(
        self,
        doc: ResultsDocument | None,
        *,
        status: JobStatus | None = None,
        error: str | None = None,
        elapsed_s: float,
        job_path: str | Path | None = None,
        source: str = "cli",
        recorded_at: float | None = None,
    ) -> int:
        """Record one checked job (the full document) or a failed one (`doc=None`, `error` and
        `job_path` given). `status` defaults to 'ok'/'findings' from the document. Returns the
        job id."""
        if doc is None and (job_path is None or error is None):
            raise ValueError("a failed job needs job_path and error")
        status = status or ("failed" if doc is None else job_status(doc))
        if status not in JOB_STATUSES:
            raise ValueError(f"status must be one of {JOB_STATUSES}, got {status!r}")
        row: dict[str, object] = {
            "recorded_at": time.time() if recorded_at is None else recorded_at,
            "source": source, "status": status, "error": error,
            "job_path": str(job_path if job_path is not None else doc.job.path),
            "elapsed_s": float(elapsed_s),
        }
        if doc is not None:
            s, job = doc.summary, doc.job
            row.update(
                part=job.part, part_hash=job.part_hash, cutter=job.cutter, machine=job.machine,
                axis_class=job.axis_class, cutter_size=job.cutter_size,
                cutter_kind=job.cutter_kind, points=s.points,
                **{f"n_{v}": getattr(s.counts, v) for v in VERDICTS},
                worst_margin=s.worst_margin, worst_depth=s.worst_depth,
                largest_safe_cutter=s.largest_safe_cutter,
                largest_safe_standard=s.largest_safe_standard_cutter,
                stock=None if doc.stock is None else stock_line(doc.stock),
                document=zlib.compress(doc.model_dump_json().encode(), 1),
                arrays=_pack_arrays(point_arrays(doc)),
            )
        names = ", ".join(row)
        marks = ", ".join("?" for _ in row)
        with self._write("recording a job") as con:
            cur = con.execute(f"INSERT INTO jobs ({names}) VALUES ({marks})", tuple(row.values()))
            return int(cur.lastrowid)

    def record_request(
        self,
        op: str,
        ok: bool,
        elapsed_s: float,
        error: str | None = None,
        job: int | None = None,
    ) -> int:
        """Record one service request; `job` is the id returned by `record_job`, if any."""
        with self._write("recording a request") as con:
            cur = con.execute(
                "INSERT INTO requests (recorded_at, op, ok, elapsed_s, error, job_id) "
                "VALUES (?, ?, ?, ?, ?, ?)",
                (time.time(), op, int(bool(ok)), float(elapsed_s), error, job),
            )
            return int(cur.lastrowid)

    def prune(
        self, *, keep_days: float | None = None, keep: int | None = None,
        now: float | None = None, vacuum: bool = False,
    ) -> Pruned:
        """Delete jobs recorded more than `keep_days` days before `now` (UTC epoch s, default
        the present) and, per job path, all but the newest `keep`; service requests older than
        `keep_days` go too, and the others forget the jobs deleted. `vacuum` then gives the
        freed pages back to the file system (rewrites the file; takes the write lock)."""
        if keep_days is None and keep is None:
            raise PathcheckError("store prune: expected --keep-days N or --keep N (or both)",
                                 code="usage")
        if keep_days is not None and not keep_days >= 0:
            raise PathcheckError(f"store prune: expected keep_days >= 0, found {keep_days}",
                                 code="usage")
        if keep is not None and not keep >= 0:
            raise PathcheckError(f"store prune: expected keep >= 0, found {keep}", code="usage")
        cutoff = (time.time() if now is None else now) - (keep_days or 0.0) * 86400.0
        with self._write("pruning") as con:
            doomed = "SELECT id FROM jobs WHERE 0"
            args: list[object] = []
            if keep_days is not None:
                doomed += " OR recorded_at < ?"
                args.append(cutoff)
            if keep is not None:
                doomed += (" OR id IN (SELECT id FROM (SELECT id, ROW_NUMBER() OVER (PARTITION BY"
                           " job_path ORDER BY recorded_at DESC, id DESC) AS k FROM jobs) "
                           "WHERE k > ?)")
                args.append(keep)
            con.execute(f"CREATE TEMP TABLE doomed AS {doomed}", args)
            con.execute("UPDATE requests SET job_id = NULL WHERE job_id IN doomed")
            requests = 0
            if keep_days is not None:
                requests = con.execute("DELETE FROM requests WHERE recorded_at < ?",
                                       (cutoff,)).rowcount
            jobs = con.execute("DELETE FROM jobs WHERE id IN doomed").rowcount
            con.execute("DROP TABLE doomed")
        if vacuum:
            with self._lock:
                try:
                    self._con.execute("VACUUM")
                except sqlite3.Error as err:
                    raise self._fail(err, "vacuuming") from err
        remaining = self._read("SELECT count(*) FROM jobs")[0][0]
        return Pruned(jobs=jobs, requests=requests, remaining=remaining)

    # ------------------------------------------------------------------ reading
    def _read(self, sql: str, args: tuple = ()) -> list[tuple]:
        with self._lock:
            try:
                return self._con.execute(sql, args).fetchall()
            except sqlite3.Error as err:
                raise self._fail(err, "reading") from err

    def jobs(self, since: float | None = None, until: float | None = None) -> list[JobRow]:
        """Recorded jobs with since <= recorded_at < until (UTC epoch s), oldest first."""
        rows = self._read(
            f"SELECT {_ROW_COLUMNS} FROM jobs WHERE recorded_at >= ? AND recorded_at < ? "
            "ORDER BY recorded_at, id",
            (-np.inf if since is None else since, np.inf if until is None else until),
        )
        return [JobRow(*r) for r in rows]

    def previous(self, job_path: str, before: float) -> JobRow | None:
        """The last record of the same job path before `before`, for trends."""
        rows = self._read(
            f"SELECT {_ROW_COLUMNS} FROM jobs WHERE job_path = ? AND recorded_at < ? "
            "ORDER BY recorded_at DESC, id DESC LIMIT 1",
            (job_path, before),
        )
        return JobRow(*rows[0]) if rows else None

    def document(self, job_id: int) -> ResultsDocument | None:
        """The full results document of a job (None for a failed job)."""
        rows = self._read("SELECT document FROM jobs WHERE id = ?", (job_id,))
        if not rows or rows[0][0] is None:
            return None
        return ResultsDocument.model_validate_json(zlib.decompress(rows[0][0]))

    def arrays(self, job_id: int) -> dict[str, np.ndarray] | None:
        """The per-point arrays of a job (see `point_arrays`), None for a failed job;
        PathcheckError (code 'corrupt') when the row's arrays cannot be read."""
        rows = self._read("SELECT arrays FROM jobs WHERE id = ?", (job_id,))
        if not rows or rows[0][0] is None:
            return None
        try:
            return _unpack_arrays(rows[0][0])
        except ValueError as err:
            raise PathcheckError(f"job {job_id}: its per-point arrays cannot be read ({err})",
                                 path=self.path, code="corrupt") from err

    def requests(self, since: float | None = None) -> list[tuple]:
        """(recorded_at, op, ok, elapsed_s, error, job_id) of service requests since `since`."""
        return self._read(
            "SELECT recorded_at, op, ok, elapsed_s, error, job_id FROM requests "
            "WHERE recorded_at >= ? ORDER BY recorded_at, id",
            (-np.inf if since is None else since,),
        )


def prune(
    path: str | Path | None = None, *, keep_days: float | None = None, keep: int | None = None,
    now: float | None = None, vacuum: bool = False,
) -> Pruned:
    """Retention: open the store at `path` (default: the configured one) and
    `ResultsStore.prune` it; PathcheckError for a store that cannot be opened or written."""
    with ResultsStore(path) as store:
        return store.prune(keep_days=keep_days, keep=keep, now=now, vacuum=vacuum)
