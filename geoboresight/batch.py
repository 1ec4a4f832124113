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
    #: Where the job comes from: "line 3" of a CSV jobs file, "job 2" otherwise.
    label: str = ""

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
    return read_labelled_jobs(path)[0]


def read_labelled_jobs(path: str) -> tuple[list[dict], list[str]]:
    """:func:`read_jobs` and where each job stands in the file ("line 3", "job 2"), for the
    messages; an empty jobs file is refused (a batch that does nothing is not a success)."""
    jobs, labels = _read_jobs(path)
    if not jobs:
        raise InputError(
            f"jobs file {path} lists no job: give one row (CSV) or object (JSON) per run"
        )
    return jobs, labels


def _read_jobs(path: str) -> tuple[list[dict], list[str]]:
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
        return jobs, [f"job {i + 1}" for i in range(len(jobs))]
    from .io.tables import read_table

    # "CSV UTF-8" from a spreadsheet (byte-order mark), ';' or tab separators: one reader.
    table = read_table(path, "jobs file")
    jobs, labels = [], []
    for n, row in zip(table.line_numbers, table.rows, strict=True):
        labels.append(f"line {n}")
        if len(row) > len(table.header):
            # Reported by its line with the other refused rows; the good rows still run.
            jobs.append(
                MalformedRow(
                    f"jobs file {path}, line {n}: {len(row)} values for {len(table.header)} "
                    f"columns ({', '.join(table.header)}): quote values that hold the "
                    f"separator {table.delimiter!r}"
                )
            )
            continue
        jobs.append({k: v for k, v in zip(table.header, row, strict=False) if k and v != ""})
    return jobs, labels


class MalformedRow(dict):
    """A jobs-file row that cannot be read as a job (more values than columns): no values,
    and the reason, which :func:`check_job` raises."""

    def __init__(self, error: str):
        super().__init__()
        self.error = error


def check_job(alg, values: dict) -> None:
    """What every job must pass before any job starts: the spec's checks (known parameters,
    types, ranges, choices) and input files that exist."""
    if isinstance(values, MalformedRow):
        raise InputError(values.error)
    checked = alg.validate(values)
    for p in alg.inputs:
        if p.kind not in ("raster", "multiraster", "file") or not checked.get(p.name):
            continue
        paths = checked[p.name] if isinstance(checked[p.name], list) else [checked[p.name]]
        for path in paths:
            if isinstance(path, str) and not os.path.exists(path):
                raise InputError(f"{p.name} {path} does not exist: check the path")


def run_batch(
    name: str,
    jobs: list[dict],
    scheduler: str | None = None,
    n_workers: int | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
    labels: list[str] | None = None,
) -> list[JobResult]:
    """Run algorithm ``name`` once per values dict in ``jobs`` on a Dask cluster.

    Every job is checked before any starts (:func:`check_job`, the checks of every face); a
    job that fails them is reported by its ``labels`` entry ("line 3") and not run, while
    the others run and are listed.

    Parameters
    ----------
    scheduler : str, optional
        Address of a running ``dask.distributed`` scheduler; by default a ``LocalCluster`` with
        one single-threaded worker process per core (``n_workers``) is started and closed, its
        scratch space in a temporary folder removed afterwards.
    """
    import shutil
    import tempfile

    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    alg = get(name)  # unknown names fail here, before a cluster starts
    progress = as_progress(progress)
    if not jobs:
        raise InputError("no job to run: give at least one")
    labels = labels or [f"job {i + 1}" for i in range(len(jobs))]
    results: list[JobResult | None] = [None] * len(jobs)
    for i, values in enumerate(jobs):
        try:
            check_job(alg, values)
        except GeoboresightError as exc:
            results[i] = JobResult(i, values, None, str(exc), labels[i])
    todo = [i for i in range(len(jobs)) if results[i] is None]
    outs = [jobs[i].get("output") for i in todo if jobs[i].get("output")]
    if len(set(map(os.path.realpath, map(str, outs)))) != len(outs):
        raise InputError("two jobs write the same output path: give each job its own output")
    for i in range(len(jobs)):
        if results[i] is not None:
            progress.info(f"{labels[i]} refused: {results[i].error}")
    if not todo:
        return [r for r in results if r is not None]
    cluster, scratch = None, None
    if scheduler:
        client = Client(scheduler)
    else:
        # Dask's scratch space (spilled data, worker folders) in the run's own folder.
        scratch = tempfile.mkdtemp(prefix="geoboresight-dask-")
        with dask.config.set({"distributed.nanny.pre-spawn-environ": worker_environ()}):
            cluster = LocalCluster(
                n_workers=min(n_workers or os.cpu_count() or 1, len(todo)),
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                local_directory=scratch,
            )
        client = Client(cluster)
    try:
        futures = {
            client.submit(_run_one, name, dict(jobs[i]), overwrite, pure=False): i for i in todo
        }
        for done, fut in enumerate(as_completed(futures), start=1):
            i = futures[fut]
            res, err = fut.result()
            results[i] = JobResult(i, jobs[i], res, err, labels[i])
            progress.update(done / len(todo), f"{labels[i]}: {'ok' if err is None else 'failed'}")
            if err is not None:
                progress.info(f"{labels[i]} failed: {err}")
        return [r for r in results if r is not None]
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
