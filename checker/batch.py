"""Batch runs: check many jobs (each against the stock and fixtures its folder states), on this
machine with a process pool or on an existing Dask distributed cluster, and record every result (or
failure, with its reason) in the store. A job that fails is recorded as failed and the batch goes
on; a job whose worker process dies (killed, out of memory) runs once more on its own and, if it
dies again, fails alone; a store that cannot record an outcome (a full disk) is said per job, and
the batch goes on."""

from __future__ import annotations

import glob
import importlib
import threading
import time
import traceback
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, replace
from multiprocessing import get_context
from pathlib import Path

from checker.errors import PathcheckError
from checker.extras import require
from checker.results import ResultsDocument
from checker.store import ResultsStore

CL_SUFFIXES = (".apt", ".aptsource", ".cl", ".cls", ".clsf", ".ncl")
DEFAULT_JOB_FUNCTION = "checker.check:check_job"


@dataclass(frozen=True)
class JobOutcome:
    """The result of one job of a batch: the results document as JSON text (None when the job
    failed) or the reason it failed; elapsed_s in seconds."""

    path: str
    document: str | None
    error: str | None
    elapsed_s: float
    unrecorded: str | None = None  # why the store could not record it (a full disk)

    def results(self) -> ResultsDocument | None:
        return None if self.document is None else ResultsDocument.model_validate_json(
            self.document
        )


def find_jobs(spec: str | Path) -> list[Path]:
    """The CL files of a directory (recursively) or matched by a glob pattern, sorted: files
    with a CL suffix (CL_SUFFIXES; one that does not read fails in the batch, named) and any
    other file whose content is APT-CL or NX CLSF (`is_cl_file`: an NX listing saved as
    `.txt`); other files (parts, G-code, notes) are skipped. A file given by name is a job."""
    from checker.apt import is_cl_file

    path = Path(spec)
    if path.is_file():
        return [path]
    if path.is_dir():
        candidates = path.rglob("*")
    else:
        candidates = (Path(p) for p in glob.glob(str(spec), recursive=True))
    found = [p for p in candidates
             if p.is_file() and (p.suffix.lower() in CL_SUFFIXES or is_cl_file(p))]
    if not found:
        raise PathcheckError(
            "expected a directory of CL files (" + ", ".join(CL_SUFFIXES) + ", or APT-CL / "
            "NX CLSF by their content) or a glob pattern that matches them, found nothing",
            path=spec, code="usage",
        )
    return sorted(found)


def _job_function(name: str) -> Callable[..., ResultsDocument]:
    module, attr = name.split(":")
    return getattr(importlib.import_module(module), attr)


def _folder_options(path: Path) -> dict:
    """The fields of a job's check options (`CheckOptions`) that its folder's `pathcheck-stock.toml`
    gives: a stock and fixtures (`checker.stock.request.folder_stock`) and a machine check
    (`machine`, `machine_clearance`: `folder_machine`), the machine loaded and its check validated
    before the run (an error names the folder's file)."""
    from checker.check.inputs import job_machine
    from checker.collide.section import asked_clearance
    from checker.stock.request import folder_machine, folder_stock

    out: dict = {}
    stock = folder_stock(path)
    if stock is not None:
        out["stock"] = stock
    asked = folder_machine(path)
    if asked is None:
        return out
    if asked.machine is None:  # the job's own (an error names the CL file)
        machine = job_machine(path, None)
    try:
        if asked.machine is not None:
            machine = job_machine(path, asked.machine)
        clearance = asked_clearance(machine, asked.clearance, check="machine_check",
                                    clearance_name="machine_clearance", code="config")
    except PathcheckError as err:  # named by the folder's file, where the check was asked
        raise PathcheckError(str(err), path=asked.file, code="config") from None
    return {**out, "machine": machine, "machine_clearance": clearance}


def run_one(path: str, job_function: str = DEFAULT_JOB_FUNCTION) -> JobOutcome:
    """Check one job (in a pool worker or on a Dask worker); never raises for a bad job. A
    folder's `pathcheck-stock.toml` gives its jobs a stock, fixtures and a machine check
    (`_folder_options`), passed as the check's options."""
    from checker.check.options import CheckOptions

    start = time.perf_counter()
    try:
        asked = _folder_options(Path(path))
        options = {"options": CheckOptions(**asked)} if asked else {}
        doc = _job_function(job_function)(path, **options)
        return JobOutcome(path, doc.model_dump_json(), None, time.perf_counter() - start)
    except PathcheckError as err:
        reason = str(err)
    except Exception as err:  # an engine fault in one job must not stop the batch
        where = traceback.extract_tb(err.__traceback__)[-1]
        reason = (
            f"{path}: internal error {type(err).__name__}: {err} "
            f"(at {Path(where.filename).name}:{where.lineno})"
        )
    return JobOutcome(path, None, reason, time.perf_counter() - start)


def _outcome(future: object, path: str, where: str) -> JobOutcome:
    """The outcome a future carries, or a failed one when the process running it died."""
    try:
        return future.result()
    except Exception as err:  # the worker crashed (killed, out of memory): this job failed
        return JobOutcome(path, None, f"{path}: the {where} died: {type(err).__name__}: {err}",
                          0.0)


# the queue a pool worker announces each job it starts on (set by `_announce_to`)
_STARTED: object | None = None


def _announce_to(queue: object) -> None:
    global _STARTED
    _STARTED = queue


def _run_announced(path: str, job_function: str) -> JobOutcome:
    """`run_one` in a pool worker, after telling the parent the job started: when the pool
    breaks, the parent knows which jobs lost their worker and which never ran."""
    _STARTED.put(path)
    return run_one(path, job_function)


def _drain(queue: object, into: set[str], stop: threading.Event) -> None:
    """Collect the started jobs' paths until `stop`, then what is left."""
    while True:
        while not queue.empty():
            into.add(queue.get())
        if stop.is_set():
            return
        stop.wait(0.05)


def _pool_round(paths: list[str], workers: int, job_function: str,
                lost: dict[str, int]) -> Iterator[JobOutcome | str]:
    """Run `paths` in one spawned pool; yield outcomes, then the paths to run again when the
    pool broke (a worker was killed or died): those that never started, and those that lost
    their worker for the first time. A job that loses its worker twice fails alone."""
    # spawned, not forked: a fork of a process whose compiled kernels already started their
    # thread pool leaves the child's pool broken (its first parallel kernel fails)
    ctx = get_context("spawn")
    started = ctx.SimpleQueue()
    ran: set[str] = set()
    stop = threading.Event()
    reader = threading.Thread(target=_drain, args=(started, ran, stop), daemon=True)
    reader.start()  # drained as it goes: workers would block on a full pipe
    unfinished: list[str] = []
    try:
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_announce_to,
                                 initargs=(started,)) as pool:
            futures = {pool.submit(_run_announced, p, job_function): p for p in paths}
            for future in as_completed(futures):
                try:
                    yield future.result()
                except BrokenProcessPool:
                    unfinished.append(futures[future])
                except Exception:
                    yield _outcome(future, futures[future], "worker process")
    finally:
        stop.set()
        reader.join(timeout=2.0)
    if unfinished and not ran.intersection(unfinished):
        ran.update(unfinished)  # died before it could say which job: all count as lost
    for path in sorted(unfinished, key=paths.index):
        if path not in ran:
            yield path
            continue
        lost[path] = lost.get(path, 0) + 1
        if lost[path] >= 2:
            yield JobOutcome(path, None, f"{path}: the worker process running it died twice "
                             "(killed, or out of memory); the other jobs went on", 0.0)
        else:
            yield path


def _local(paths: list[str], workers: int, job_function: str) -> Iterator[JobOutcome]:
    """Jobs in a process pool; after a pool breaks, the jobs that lost their worker run again
    one at a time (so that a job that kills its worker again fails alone), then the rest in a
    new pool."""
    if workers <= 1:
        yield from (run_one(p, job_function) for p in paths)
        return
    lost: dict[str, int] = {}
    todo = list(paths)
    while todo:
        retry = [p for p in todo if lost.get(p)]
        rounds = [[p] for p in retry] + [[p for p in todo if not lost.get(p)]]
        todo = []
        for batch in rounds:
            if not batch:
                continue
            for item in _pool_round(batch, 1 if len(batch) == 1 else workers, job_function,
                                    lost):
                if isinstance(item, str):
                    todo.append(item)
                else:
                    yield item


DASK_RETRIES = 1  # as the local pool's "once more"


def run_on_dask(path: str, job_function: str = DEFAULT_JOB_FUNCTION) -> JobOutcome:
    """`run_one` in a Dask worker thread with one numba thread (numba's count is per calling
    thread): a worker with T threads runs T jobs at once on T cores, not T x cores threads."""
    try:
        import numba
    except ImportError:  # a job function that needs no kernels
        pass
    else:
        numba.set_num_threads(1)
    return run_one(path, job_function)


def _dask(
    paths: list[str], scheduler: object, job_function: str, connect_timeout_s: float
) -> Iterator[JobOutcome]:
    """Jobs on a Dask cluster: `scheduler` is an address ('tcp://host:8786') or a Client. A
    task that raises on its worker (outside `run_one`: it cannot be unpickled there, a
    BaseException) runs DASK_RETRIES more times; one whose worker dies is rescheduled by the
    scheduler (`distributed.scheduler.allowed-failures`) and then fails alone (KilledWorker)."""
    require("distributed", "dask", "running jobs on a Dask cluster")
    from distributed import Client
    from distributed import as_completed as dask_completed

    own = not isinstance(scheduler, Client)
    try:
        client = Client(scheduler, timeout=connect_timeout_s) if own else scheduler
    except (OSError, TimeoutError) as err:
        raise PathcheckError(
            f"cannot reach the Dask scheduler: {err}", path=str(scheduler), code="usage"
        ) from err
    try:
        futures = client.map(run_on_dask, paths, job_function=job_function, pure=False,
                             retries=DASK_RETRIES)
        path_of = {f.key: p for f, p in zip(futures, paths, strict=True)}
        for future in dask_completed(futures):
            yield _outcome(future, path_of[future.key], "Dask worker")
    finally:
        if own:
            client.close()


def run_batch(
    paths: list[str | Path],
    *,
    store: ResultsStore | None,
    workers: int = 1,
    scheduler: object | None = None,
    job_function: str = DEFAULT_JOB_FUNCTION,
    on_result: Callable[[JobOutcome], None] | None = None,
    connect_timeout_s: float = 10.0,
) -> list[JobOutcome]:
    """Check every job, record each outcome in `store` as it arrives (source 'batch'), call
    `on_result` (progress), and return the outcomes in the order of `paths`. With `scheduler`
    (a Dask address or Client) the jobs run on that cluster, else in `workers` processes."""
    names = [str(p) for p in paths]
    if scheduler is not None:
        stream = _dask(names, scheduler, job_function, connect_timeout_s)
    else:
        stream = _local(names, workers, job_function)
    outcomes: dict[str, JobOutcome] = {}
    for outcome in stream:
        if store is not None:
            try:
                store.record_job(
                    outcome.results(), error=outcome.error, job_path=outcome.path,
                    elapsed_s=outcome.elapsed_s, source="batch",
                )
            except PathcheckError as err:  # a full disk: say so, the other jobs go on
                outcome = replace(outcome, unrecorded=str(err))
        outcomes[outcome.path] = outcome
        if on_result is not None:
            on_result(outcome)
    return [outcomes[n] for n in names]
