"""Many flight lines at once on Dask (``dask.distributed``), never a home-made scheduler.

Each job is one ordinary run of an algorithm spec (one flight line, one set of values); jobs
are independent, so they are submitted as Dask tasks to a ``LocalCluster`` (default) or to a
running scheduler (``scheduler="tcp://host:8786"``) for a real cluster. A job that fails
reports its error and, like any run, leaves no output behind; the others carry on.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

from .algorithms import execute, get
from .errors import GeoboresightError, InputError
from .progress import Progress, as_progress


@dataclass(frozen=True)
class JobResult:
    """The outcome of one job: its values, and either its results or its error message."""

    index: int
    values: dict
    result: dict | None
    error: str | None

    @property
    def ok(self) -> bool:
        return self.error is None


def _run_one(name: str, values: dict, overwrite: bool) -> tuple[dict | None, str | None]:
    try:
        return execute(get(name), values, overwrite=overwrite), None
    except GeoboresightError as exc:
        return None, str(exc)


def worker_environ() -> dict:
    """The environment Dask's nannies give worker processes, without ``MALLOC_TRIM_THRESHOLD_``.

    Dask sets it (65,536) to hand memory back sooner; setting it switches off glibc's dynamic
    mmap threshold, so every strip-sized NumPy temporary is mapped and unmapped again, page
    faults included: the relative DEM of a 2,000-line line took 5.5–5.8 s in such a worker
    against 2.0 s without it (the operations give memory back themselves, strip by strip).
    The one-thread BLAS/OpenMP settings are kept (one worker per core). For workers started
    apart (``dask worker``), set the same with ``distributed.nanny.pre-spawn-environ`` or start
    them with ``--no-nanny``.
    """
    import dask

    environ = dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {}
    return {k: v for k, v in environ.items() if k != "MALLOC_TRIM_THRESHOLD_"}


def read_jobs(path: str) -> list[dict]:
    """Jobs from a JSON list of objects, or a CSV whose header names the parameters (comma,
    semicolon or tab separated, with or without a byte-order mark: :mod:`geoboresight.io.tables`);
    empty cells are left out (the parameter's default)."""
    if not os.path.exists(path):
        raise InputError(f"jobs file {path} does not exist")
    if path.lower().endswith(".json"):
        with open(path, encoding="utf-8-sig") as f:
            try:
                jobs = json.load(f)
            except json.JSONDecodeError as exc:
                raise InputError(f"jobs file {path} is not valid JSON ({exc})") from None
        if not isinstance(jobs, list) or not all(isinstance(j, dict) for j in jobs):
            raise InputError(f"jobs file {path}: expected a JSON list of objects (one per job)")
        return jobs
    from .io.tables import read_table

    # "CSV UTF-8" from a spreadsheet (byte-order mark), ';' or tab separators: one reader.
    table = read_table(path, "jobs file")
    jobs = []
    for n, row in zip(table.line_numbers, table.rows, strict=True):
        if len(row) > len(table.header):
            raise InputError(
                f"jobs file {path}, line {n}: {len(row)} values for {len(table.header)} "
                f"columns ({', '.join(table.header)}): quote values that hold the separator "
                f"{table.delimiter!r}"
            )
        jobs.append({k: v for k, v in zip(table.header, row, strict=False) if k and v != ""})
    return jobs


def run_batch(
    name: str,
    jobs: list[dict],
    scheduler: str | None = None,
    n_workers: int | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> list[JobResult]:
    """Run algorithm ``name`` once per values dict in ``jobs`` on a Dask cluster.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running ``dask.distributed`` scheduler; by default a ``LocalCluster`` with
        one single-threaded worker process per core (``n_workers``) is started and closed.
    """
    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    get(name)  # unknown names fail here, before a cluster starts
    progress = as_progress(progress)
    outs = [j.get("output") for j in jobs if j.get("output")]
    if len(set(map(os.path.realpath, outs))) != len(outs):
        raise InputError("two jobs write the same output path: give each job its own output")
    cluster = None
    if scheduler:
        client = Client(scheduler)
    else:
        with dask.config.set({"distributed.nanny.pre-spawn-environ": worker_environ()}):
            cluster = LocalCluster(
                n_workers=n_workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
            )
        client = Client(cluster)
    try:
        futures = {
            client.submit(_run_one, name, dict(v), overwrite, pure=False): i
            for i, v in enumerate(jobs)
        }
        results: list[JobResult | None] = [None] * len(jobs)
        for done, fut in enumerate(as_completed(futures), start=1):
            i = futures[fut]
            res, err = fut.result()
            results[i] = JobResult(i, jobs[i], res, err)
            progress.update(done / len(jobs), f"job {i + 1}: {'ok' if err is None else 'failed'}")
            if err is not None:
                progress.info(f"job {i + 1} failed: {err}")
        return [r for r in results if r is not None]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
