"""The executors (:mod:`tableclean_suite.executors`): same results on any executor and any number
of workers, retries of failed tasks, errors naming the task, and the harness's cells through them
(bit-identical files).  Ray runs on a private cluster bound to loopback with 2 CPUs."""

import builtins
import os
import subprocess
import sys
from pathlib import Path

import pytest
import ray  # the dev extra installs it: these tests run wherever the README's set-up ran

from tableclean_suite.executors import (LocalExecutor, MissingRayError, RayExecutor, TaskFailedError, make_executor)
from tableclean_suite.executors.probes import ProbeTask, run_probe

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


@pytest.mark.parametrize("workers", [None, 1, 2])
def test_ray_gives_the_local_results(local_ray, workers):
    with RayExecutor(workers=workers) as executor:
        assert list(executor.map(run_probe, probes())) == expected()
    assert ray.is_initialized()  # a Ray the caller started is left running


@pytest.mark.parametrize("mode", ["retry_once", "crash_once"])
def test_ray_retries_a_task_that_fails_once(local_ray, mode, tmp_path):
    tasks = probes()
    tasks[5] = ProbeTask(5, seed=7, mode=mode, marker=str(tmp_path / "marker"))
    with RayExecutor(max_retries=1) as executor:
        assert list(executor.map(run_probe, tasks)) == expected()


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
    lines = [line for line in result.stdout.splitlines() if not line.startswith(("cells:", "done in"))]
    return "\n".join(lines).replace(str(out), "OUT")


def cell_files(out) -> dict:
    return {path.name: path.read_bytes() for path in sorted((out / "cells").glob("*.npz"))}


@pytest.fixture(scope="module")
def serial_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    return out, run_cli(out)


@pytest.mark.parametrize("args", [("--workers", "2"), ("--workers", "3"), ("--executor", "ray", "--workers", "2")],
                         ids=["local-2", "local-3", "ray"])
def test_cells_through_an_executor_are_bit_identical_to_the_serial_run(serial_sweep, args, tmp_path):
    serial_out, serial = serial_sweep
    result = run_cli(tmp_path, *args)
    for name in OUTPUT_FILES:
        assert (tmp_path / name).read_bytes() == (serial_out / name).read_bytes(), name
    assert cell_files(tmp_path) == cell_files(serial_out) and len(cell_files(serial_out)) == 4
    assert printed_tables(result, tmp_path) == printed_tables(serial, serial_out)
    assert "Traceback" not in result.stderr
