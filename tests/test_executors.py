"""The executors (:mod:`tableclean_suite.executors`): same results on any executor and any number
of workers, retries of failed tasks, errors naming the task, and the harness's cells through them
(bit-identical files).  Ray runs on a private cluster bound to loopback with 2 CPUs."""

import builtins
import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest

try:
    import ray  # the dev extra installs it: these tests run wherever the README's set-up ran
except ImportError:
    ray = None

import executor_probes
from executor_probes import ProbeTask, run_probe
from tableclean_suite.executors import (LocalExecutor, MissingRayError, RayExecutor, TaskFailedError, make_executor)

if ray is not None:  # Ray workers cannot import the tests' modules: the probes travel by value
    ray.cloudpickle.register_pickle_by_value(executor_probes)

#: The Ray tests run wherever Ray imports (the dev and cluster extras install it, so CI runs them).
needs_ray = pytest.mark.skipif(ray is None, reason="Ray is not installed: pip install -e '.[dev]' (or '.[cluster]')")

ROOT = Path(__file__).resolve().parents[1]
#: Probes per map: more than the workers, so tasks queue.
PROBES = 6
#: The small symbolic sweep: 2 learners x 2 rewards, 50 runs x 500 iterations.
SWEEP = ["--learners", "q_learning,sarsa", "--rewards", "r2,r4", "--runs", "50", "--iterations", "500",
         "--no-sweeps", "--no-literature", "--no-figures", "--no-progress"]
OUTPUT_FILES = ("table3.csv", "table4.csv", "curves.csv", "comparisons.csv")
LOCAL_RAY = {"RAY_USAGE_STATS_ENABLED": "0"}

def probes(**kwargs):
    return [ProbeTask(i, seed=7, **kwargs) for i in range(PROBES)]


def expected():
    return [run_probe(task) for task in probes()]


# --- local executor ---------------------------------------------------------------------------


@pytest.mark.parametrize("workers", [1, 2, 3])
def test_local_results_in_task_order_whatever_the_workers(workers):
    with LocalExecutor(workers=workers) as executor:
        assert list(executor.map(run_probe, probes())) == expected()


def test_map_outside_with_starts_and_stops_the_pool():
    executor = LocalExecutor(workers=2)
    assert list(executor.map(run_probe, probes())) == expected()
    assert executor._pool is None


@pytest.mark.parametrize("workers", [1, 2])
def test_a_task_that_fails_once_is_retried_and_succeeds(workers, tmp_path):
    tasks = probes()
    tasks[3] = ProbeTask(3, seed=7, mode="retry_once", marker=str(tmp_path / "marker"))
    with LocalExecutor(workers=workers, max_retries=1) as executor:
        assert list(executor.map(run_probe, tasks)) == expected()
    assert (tmp_path / "marker").exists()


def test_a_worker_that_dies_once_is_replaced_and_its_task_rerun(tmp_path):
    tasks = probes()
    tasks[2] = ProbeTask(2, seed=7, mode="crash_once", marker=str(tmp_path / "marker"))
    with LocalExecutor(workers=2, max_retries=1) as executor:
        assert list(executor.map(run_probe, tasks)) == expected()
        assert list(executor.map(run_probe, probes())) == expected()  # the new pool keeps working


@pytest.mark.parametrize("workers, mode", [(1, "retry_always"), (2, "retry_always"), (2, "crash_always")])
def test_a_task_that_always_fails_raises_naming_it(workers, mode):
    tasks = probes()
    tasks[4] = ProbeTask(4, seed=7, mode=mode)
    with LocalExecutor(workers=workers, max_retries=2) as executor:
        with pytest.raises(TaskFailedError, match=f"task probe-4:{mode} failed after 3 attempts") as caught:
            list(executor.map(run_probe, tasks))
        assert caught.value.task == tasks[4] and caught.value.attempts == 3
        assert list(executor.map(run_probe, probes())) == expected()


@pytest.mark.parametrize("workers", [1, 2])
def test_a_plain_error_is_not_retried(workers):
    tasks = probes()
    tasks[1] = ProbeTask(1, seed=7, mode="error")
    with LocalExecutor(workers=workers, max_retries=5) as executor:
        with pytest.raises(TaskFailedError, match="probe-1:error failed after 1 attempt: ValueError") as caught:
            list(executor.map(run_probe, tasks))
    assert isinstance(caught.value.__cause__, ValueError)


def test_bad_options_and_functions_are_refused():
    with pytest.raises(ValueError, match="workers must be an integer >= 1, got 0"):
        LocalExecutor(workers=0)
    with pytest.raises(ValueError, match="max_retries must be an integer >= 0, got -1"):
        make_executor("local", max_retries=-1)
    with pytest.raises(ValueError, match="unknown executor 'spark'; allowed: local, ray"):
        make_executor("spark")
    with pytest.raises(ValueError, match="only used by the ray executor"):
        make_executor("local", address="auto")
    with pytest.raises(TypeError, match="module level"):
        LocalExecutor().map(lambda task: task, [1])


def test_missing_ray_names_the_cluster_extra(monkeypatch):
    real_import = builtins.__import__

    def no_ray(name, *args, **kwargs):
        if name == "ray":
            raise ImportError("No module named 'ray'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_ray)
    with pytest.raises(MissingRayError, match=r"tableclean_suite\[cluster\]"):
        list(RayExecutor().map(run_probe, probes()))


# --- Ray executor (a private Ray on loopback, 2 CPUs) --------------------------------------------


@pytest.fixture(scope="module")
def local_ray():
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")
    ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1", log_to_driver=False)
    yield
    ray.shutdown()


@needs_ray
@pytest.mark.parametrize("workers", [None, 1, 2])
def test_ray_gives_the_local_results(local_ray, workers):
    with RayExecutor(workers=workers) as executor:
        assert list(executor.map(run_probe, probes())) == expected()
    assert ray.is_initialized()  # a Ray the caller started is left running


@needs_ray
@pytest.mark.parametrize("mode", ["retry_once", "crash_once"])
def test_ray_retries_a_task_that_fails_once(local_ray, mode, tmp_path):
    tasks = probes()
    tasks[5] = ProbeTask(5, seed=7, mode=mode, marker=str(tmp_path / "marker"))
    with RayExecutor(max_retries=1) as executor:
        assert list(executor.map(run_probe, tasks)) == expected()


@needs_ray
@pytest.mark.parametrize("mode, attempts", [("retry_always", 2), ("crash_always", 2), ("error", 1)])
def test_ray_raises_naming_a_task_that_keeps_failing(local_ray, mode, attempts):
    tasks = probes()
    tasks[0] = ProbeTask(0, seed=7, mode=mode)
    with RayExecutor(max_retries=1) as executor:
        with pytest.raises(TaskFailedError, match=f"task probe-0:{mode} failed after {attempts} attempt") as caught:
            list(executor.map(run_probe, tasks))
    assert caught.value.attempts == attempts


# --- the harness's cells through the executors ----------------------------------------------------


def run_cli(out, *args):
    env = {**os.environ, **LOCAL_RAY}  # default thread counts: the results must not depend on them
    result = subprocess.run([sys.executable, "-m", "benchmarks.run", *SWEEP, *args, "--out", str(out)], cwd=ROOT,
                            env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return result


def printed_tables(result, out) -> str:
    """stdout without the timing lines and with the output directory masked."""
    lines = [line for line in result.stdout.splitlines()
             if not line.startswith(("cells:", "done in", "derived results"))]
    return "\n".join(lines).replace(str(out), "OUT")


def cell_files(out) -> dict:
    return {path.name: path.read_bytes() for path in sorted((out / "cells").glob("*.npz"))}


@pytest.fixture(scope="module")
def serial_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return out, run_cli(out)


@pytest.mark.parametrize("args", [("--workers", "2"), ("--workers", "3"),
                                  pytest.param(("--executor", "ray", "--workers", "2"), marks=needs_ray)],
                         ids=["local-2", "local-3", "ray"])
def test_cells_through_an_executor_are_bit_identical_to_the_serial_run(serial_sweep, args, tmp_path):
    serial_out, serial = serial_sweep
    result = run_cli(tmp_path, *args)
    for name in OUTPUT_FILES:
        assert (tmp_path / name).read_bytes() == (serial_out / name).read_bytes(), name
    assert cell_files(tmp_path) == cell_files(serial_out) and len(cell_files(serial_out)) == 4
    assert printed_tables(result, tmp_path) == printed_tables(serial, serial_out)
    assert "Traceback" not in result.stderr


# --- physics workloads on Ray: the same results as the local executor ------------------------------


#: The smallest fidelity run: 2 rounds (2 tasks) of the move skill from the paper's 18 states.
FIDELITY = ["--trials", "2", "--actions", "move", "--seed", "5", "--quiet"]
#: Columns that measure time, not what happened.
TIMING_COLUMNS = ("wall_time", "env_time", "mean_seconds")


def run_fidelity(out, *args):
    env = {key: value for key, value in os.environ.items() if key != "RAY_ADDRESS"}  # --executor ray: a private Ray
    result = subprocess.run([sys.executable, "-m", "benchmarks.fidelity", *FIDELITY, *args, "--out", str(out)],
                            cwd=ROOT, env={**env, **LOCAL_RAY}, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr
    return result


def csv_rows(path) -> list[dict]:
    with open(path, newline="") as handle:
        return [{k: v for k, v in row.items() if k not in TIMING_COLUMNS} for row in csv.DictReader(handle)]


@pytest.mark.slow
@needs_ray
def test_fidelity_rounds_on_a_private_ray_give_the_local_results(tmp_path):
    """``--executor ray`` without an address starts a private Ray on loopback: same trials, pairs and skills."""
    run_fidelity(tmp_path / "local")
    on_ray = run_fidelity(tmp_path / "ray", "--executor", "ray", "--workers", "2")
    assert "36 trials in 2 round(s)" in on_ray.stdout
    pairs = (tmp_path / "ray" / "fidelity_pairs.csv").read_bytes()
    assert pairs == (tmp_path / "local" / "fidelity_pairs.csv").read_bytes()
    assert len(csv_rows(tmp_path / "ray" / "fidelity_pairs.csv")) == 18
    for name in ("fidelity_trials.csv", "fidelity_skills.csv"):
        ray_rows, local_rows = csv_rows(tmp_path / "ray" / name), csv_rows(tmp_path / "local" / name)
        assert ray_rows == local_rows and ray_rows, name
    assert {row["round"] for row in csv_rows(tmp_path / "ray" / "fidelity_trials.csv")} == {"0", "1"}


@pytest.mark.slow
@needs_ray
def test_demo_collection_on_ray_writes_the_local_dataset(local_ray, tmp_path):
    """Each demo attempt is a task seeded by (seed, attempt): Ray's file holds this process's data."""
    pytest.importorskip("h5py", reason="demo collection needs h5py (the demos and dev extras)")
    from hdf5_differences import dataset_differences
    from tableclean_suite.bench import collect_demos
    from tableclean_suite.demos import demo_keys

    common = ["--task", "paper", "--episodes", "2", "--seed", "11"]
    assert collect_demos.main([*common, "--out", str(tmp_path / "local.hdf5")]) == 0
    assert collect_demos.main([*common, "--executor", "ray", "--workers", "2", "--out", str(tmp_path / "ray.hdf5")]) == 0
    assert ray.is_initialized()  # the caller's Ray is left running
    assert dataset_differences(tmp_path / "local.hdf5", tmp_path / "ray.hdf5") == []
    assert demo_keys(tmp_path / "ray.hdf5") == ["demo_0", "demo_1"]


# --- one BLAS thread inside physics tasks ----------------------------------------------------------


def test_single_blas_thread_pins_every_loaded_openblas_and_restores_it():
    import numpy  # noqa: F401  (its wheel loads OpenBLAS)
    import scipy.linalg  # noqa: F401  (so does scipy's)

    from tableclean_suite.executors.blas import loaded_openblas, single_blas_thread

    def blas_threads():
        return {path: int(getter()) for path, getter, _ in loaded_openblas()}

    libraries = loaded_openblas()
    assert libraries, "numpy's and scipy's wheels ship OpenBLAS: none was found in /proc/self/maps"
    for _, _, setter in libraries:
        setter(2)
    before = blas_threads()
    with single_blas_thread():
        assert set(blas_threads().values()) == {1} and set(blas_threads()) == set(before)
    assert blas_threads() == before
    with pytest.raises(ZeroDivisionError):
        with single_blas_thread():
            1 / 0
    assert blas_threads() == before


def test_a_broken_pool_names_the_lowest_task_that_used_up_its_attempts():
    """A crash charges every task running in the pool; when two use up their attempts together, the one
    named is the lowest-indexed (the crashing task, submitted first), whatever order the futures end in."""
    from concurrent.futures import Future
    from concurrent.futures.process import BrokenProcessPool

    tasks = probes()
    futures = [Future(), Future()]
    for future in futures:
        future.set_exception(BrokenProcessPool("a worker died"))
    running = {futures[0]: 5, futures[1]: 4}  # the higher index first
    executor = LocalExecutor(workers=2, max_retries=2)
    broken, failure = executor._collect(list(running), dict(running), {}, [], tasks, [3] * len(tasks))
    assert broken and failure[0] == 4 and failure[1].task == tasks[4]
