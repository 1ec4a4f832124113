"""Many flight lines on a dask.distributed LocalCluster: same outputs as serial runs."""

import json
import os

import numpy as np
import rasterio
from click.testing import CliRunner
from synth import SWIR_WL, VNIR_WL, cube, write_envi

from geoboresight.batch import run_batch
from geoboresight.cli import main


def test_batch_equals_serial_and_isolates_a_failing_job(tmp_path):
    jobs = []
    for k in range(3):
        v = write_envi(tmp_path / f"v{k}.img", cube(len(VNIR_WL), seed=20 + k), VNIR_WL)
        s = write_envi(tmp_path / f"s{k}.img", cube(len(SWIR_WL), seed=30 + k), SWIR_WL)
        jobs.append({"vnir": v, "swir": s, "output": str(tmp_path / f"r{k}.tif")})
    jobs.append({"vnir": str(tmp_path / "missing.img"), "output": str(tmp_path / "bad.tif")})
    results = run_batch("ratio", jobs, n_workers=2)
    assert [r.ok for r in results] == [True, True, True, False]
    assert "missing.img does not exist" in results[3].error
    assert not (tmp_path / "bad.tif").exists()
    from geoboresight.algorithms import get

    for k in range(3):
        get("ratio")(vnir=jobs[k]["vnir"], swir=jobs[k]["swir"], output=tmp_path / f"serial{k}.tif")
        with (
            rasterio.open(tmp_path / f"r{k}.tif") as a,
            rasterio.open(tmp_path / f"serial{k}.tif") as b,
        ):
            np.testing.assert_array_equal(a.read(1), b.read(1))
    # The CLI front: a JSON jobs file; a failed job makes the command fail, naming it.
    (tmp_path / "jobs.json").write_text(json.dumps(jobs[3:]))
    r = CliRunner().invoke(main, ["batch", "ratio", str(tmp_path / "jobs.json"), "--workers", "1"])
    assert r.exit_code == 1 and "job 1: FAILED" in r.output


def test_local_workers_keep_glibcs_dynamic_mmap_threshold():
    """Dask's nannies set MALLOC_TRIM_THRESHOLD_, which switches glibc's dynamic mmap threshold
    off (every strip temporary mapped again: 2–3× slower operations); batch's local workers get
    Dask's other settings (one BLAS/OpenMP thread per worker) without it."""
    import dask

    from geoboresight.batch import worker_environ

    env = worker_environ()
    assert "MALLOC_TRIM_THRESHOLD_" not in env
    default = dask.config.get("distributed.nanny.pre-spawn-environ")
    assert env == {k: v for k, v in default.items() if k != "MALLOC_TRIM_THRESHOLD_"}


def test_a_jobs_file_is_checked_whole_and_bad_rows_named_while_good_rows_run(tmp_path):
    """A spreadsheet's jobs CSV: a row with a wrong type and a row with a missing file are
    reported by their line before any job starts; the good rows run; Dask leaves nothing."""
    import glob
    import tempfile

    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL), seed=1), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL), seed=2), SWIR_WL)
    rows = [
        "vnir;swir;output;tolerance_nm",
        f"{v};{s};{tmp_path / 'a.tif'};10",
        f"{v};{s};{tmp_path / 'b.tif'};ten",
        f"{tmp_path / 'nope.img'};{s};{tmp_path / 'c.tif'};10",
        f"{v};{s};{tmp_path / 'd.tif'};5",
    ]
    (tmp_path / "jobs.csv").write_text("\ufeff" + "\n".join(rows) + "\n", encoding="utf-8")
    before = set(glob.glob(os.path.join(tempfile.gettempdir(), "geoboresight-dask-*")))
    r = CliRunner().invoke(main, ["batch", "ratio", str(tmp_path / "jobs.csv"), "--workers", "1"])
    assert r.exit_code == 1, r.output
    assert "line 3: FAILED" in r.output and "'tolerance_nm'" in r.output
    assert "line 4: FAILED" in r.output and "nope.img does not exist" in r.output
    assert "line 2: ok" in r.output and "line 5: ok" in r.output
    assert (tmp_path / "a.tif").exists() and (tmp_path / "d.tif").exists()
    assert not (tmp_path / "b.tif").exists() and not (tmp_path / "c.tif").exists()
    assert "2 of 4 jobs failed" in r.output
    after = set(glob.glob(os.path.join(tempfile.gettempdir(), "geoboresight-dask-*")))
    assert after == before


def test_an_empty_jobs_file_is_refused(tmp_path):
    (tmp_path / "jobs.csv").write_text("vnir,swir,output\n")
    r = CliRunner().invoke(main, ["batch", "ratio", str(tmp_path / "jobs.csv")])
    assert r.exit_code == 1 and "lists no job" in r.output
    (tmp_path / "jobs.json").write_text("[]")
    r = CliRunner().invoke(main, ["batch", "ratio", str(tmp_path / "jobs.json")])
    assert r.exit_code == 1 and "lists no job" in r.output


def test_a_row_with_too_many_values_is_reported_by_its_line_while_the_good_rows_run(tmp_path):
    v = write_envi(tmp_path / "v.img", cube(len(VNIR_WL), seed=1), VNIR_WL)
    s = write_envi(tmp_path / "s.img", cube(len(SWIR_WL), seed=2), SWIR_WL)
    rows = [
        "vnir,swir,output",
        f"{v},{s},{tmp_path / 'a.tif'}",
        f"{v},{s},{tmp_path / 'b.tif'},10",
        f"{v},{s},{tmp_path / 'c.tif'}",
    ]
    (tmp_path / "jobs.csv").write_text("\n".join(rows) + "\n")
    r = CliRunner().invoke(main, ["batch", "ratio", str(tmp_path / "jobs.csv"), "--workers", "1"])
    assert r.exit_code == 1, r.output
    assert "line 3: FAILED" in r.output and "4 values for 3 columns" in r.output
    assert "line 2: ok" in r.output and "line 4: ok" in r.output
    assert (tmp_path / "a.tif").exists() and (tmp_path / "c.tif").exists()
    assert not (tmp_path / "b.tif").exists()


def test_the_hostile_cases_in_batch(tmp_path):
    """hostile.FACE_CASES as a Dask batch meets them, one batch per operation: each job's
    result (with the warning of an accepted repeat) or its one-line error naming the file and
    the parameter as Python names it ('vnir_dark'); a Specim capture's image lines only."""
    import dask
    from dask.distributed import LocalCluster
    from hostile import COLS, FACE_CASES, ROWS, face_values, make_face_inputs, make_products

    from geoboresight.batch import worker_environ

    d = make_face_inputs(tmp_path / "in")
    by_op = {}
    for case in FACE_CASES:
        by_op.setdefault(case.op, []).append(case)
    # One cluster for the batches of every operation, as run_batch makes its own (one
    # single-threaded worker process), given by its address; the last batch below makes its own.
    with dask.config.set({"distributed.nanny.pre-spawn-environ": worker_environ()}):
        cluster = LocalCluster(
            n_workers=1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            local_directory=str(tmp_path / "dask"),
        )
    with cluster:
        for op, cases in by_op.items():
            values = [face_values(c, d, tmp_path) for c in cases]
            results = run_batch(op, values, scheduler=cluster.scheduler_address)
            for case, res in zip(cases, results, strict=True):
                assert res.ok == (case.code == 0), (case.id, res.error)
                if res.ok:
                    assert any(case.warning in w for w in res.result["warnings"]), case.id
                    continue
                assert "\n" not in res.error
                for expect in case.expect:
                    assert expect in res.error, (case.id, expect, res.error)
                if case.param:
                    assert f"'{case.param}'" in res.error, res.error
    p = make_products(tmp_path / "p")["specim"]
    [res] = run_batch("stats", [{"input": p.path, "band": 2, "output": str(tmp_path / "s.json")}])
    assert res.ok and res.result["n"] == ROWS * COLS
