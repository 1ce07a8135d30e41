"""Fault battery, bounded waits and clean exits: an unreachable Ray cluster is refused in seconds naming
its address, local workers die with their parent, Ctrl-C is one line and exit 130, and a script
without a ``__main__`` guard is named as the cause of its dead workers."""

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tableclean_suite.executors import ClusterUnreachableError, LocalExecutor, RayExecutor
from tableclean_suite.executors import local as local_executor
from tableclean_suite.executors.ray_executor import check_reachable, host_and_port

from publication_check import check_outputs

ROOT = Path(__file__).resolve().parents[1]
#: Seconds a killed parent's workers may take to notice (they check every PARENT_CHECK_SECONDS).
ORPHAN_GRACE = 10 * local_executor.PARENT_CHECK_SECONDS


def _closed_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]  # closed again when the with block ends


@pytest.mark.parametrize("address, expected", [("10.0.0.5:6379", ("10.0.0.5", 6379)),
                                               ("ray://head:10001", ("head", 10001)), ("auto", None),
                                               ("[::1]:6379", ("::1", 6379)), ("host:port", None)])
def test_host_and_port(address, expected):
    assert host_and_port(address) == expected


def test_an_unreachable_cluster_is_refused_at_once_naming_its_address():
    address = f"127.0.0.1:{_closed_port()}"
    started = time.monotonic()
    with pytest.raises(ClusterUnreachableError, match=address.replace(".", r"\.")):
        check_reachable(address, timeout=5)
    assert time.monotonic() - started < 5


def test_the_connect_timeout_bounds_the_wait(monkeypatch):
    def silent(target, timeout):
        raise TimeoutError("timed out")

    monkeypatch.setattr(socket, "create_connection", silent)
    with pytest.raises(ClusterUnreachableError, match=r"within 2 s \(timed out\)"):
        check_reachable("192.0.2.1:6379", timeout=2)


@pytest.mark.parametrize("timeout", [0, -1, float("inf"), "30", True])
def test_a_bad_connect_timeout_is_refused(timeout):
    with pytest.raises(ValueError, match="connect_timeout"):
        RayExecutor(address="127.0.0.1:6379", connect_timeout=timeout)


def test_ray_executor_refuses_an_unreachable_address_before_ray_init(monkeypatch):
    pytest.importorskip("ray")
    import ray

    def never(*args, **kwargs):
        raise AssertionError("ray.init was called")

    monkeypatch.setattr(ray, "init", never)
    executor = RayExecutor(address=f"127.0.0.1:{_closed_port()}", connect_timeout=5)
    with pytest.raises(ClusterUnreachableError):
        executor.start()


@pytest.mark.parametrize("source, named", [("print('hi')\n", True),
                                           ("if __name__ == '__main__':\n    print('hi')\n", False),
                                           ('if __name__=="__main__": main()\n', False)])
def test_the_main_guard_hint(tmp_path, monkeypatch, source, named):
    script = tmp_path / "script.py"
    script.write_text(source)
    fake_main = type(sys)("__main__")
    fake_main.__file__ = str(script)
    monkeypatch.setitem(sys.modules, "__main__", fake_main)
    hint = local_executor.main_guard_hint()
    assert bool(hint) == named and (not named or "__main__" in hint and str(script) in hint)


@pytest.mark.cli
def test_a_script_without_a_main_guard_names_the_cause(tmp_path):
    script = tmp_path / "noguard.py"
    script.write_text(f"import sys\nsys.path.insert(0, {str(Path(__file__).parent)!r})\n"
                      "from tableclean_suite.executors import LocalExecutor, TaskFailedError\n"
                      "from executor_probes import ProbeTask, run_probe\n"
                      "try:\n    list(LocalExecutor(workers=2).map(run_probe, [ProbeTask(i, seed=1) for i in range(2)]))\n"
                      "except TaskFailedError as error:\n    print('ERROR:', error)\n")
    result = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert "ERROR:" in result.stdout and "guard" in result.stdout and str(script) in result.stdout, result.stdout


PARENT = """
import sys, time
from tableclean_suite.executors import LocalExecutor

def nap(seconds):
    import os, time
    print(os.getpid(), flush=True)
    time.sleep(seconds)
    return seconds

if __name__ == "__main__":
    with LocalExecutor(workers=2) as executor:
        list(executor.map(nap, [120, 120]))
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie (exited, not yet reaped by init) counts as gone
        with open(f"/proc/{pid}/stat") as handle:
            return handle.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return False


@pytest.mark.cli
def test_workers_die_with_a_killed_parent(tmp_path):
    script = tmp_path / "parent.py"
    script.write_text(PARENT)
    parent = subprocess.Popen([sys.executable, str(script)], cwd=tmp_path, stdout=subprocess.PIPE, text=True,
                              env={**os.environ, "PYTHONPATH": str(ROOT)})
    workers = [int(parent.stdout.readline()) for _ in range(2)]
    assert all(_alive(pid) for pid in workers)
    parent.kill()  # kill -9: no clean-up in the parent
    parent.wait()
    deadline = time.monotonic() + ORPHAN_GRACE
    while any(_alive(pid) for pid in workers) and time.monotonic() < deadline:
        time.sleep(0.2)
    assert not any(_alive(pid) for pid in workers)


@pytest.mark.cli
def test_ctrl_c_is_one_line_and_exit_130_with_workers(tmp_path):
    out = tmp_path / "out"
    # a budget no busy machine finishes before the interrupt: the first cell may be saved only late
    run = subprocess.Popen([sys.executable, "-m", "benchmarks.run", "--workers", "2", "--runs", "20000",
                            "--iterations", "30000", "--no-figures", "--no-progress", "--out", str(out)], cwd=ROOT,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                           # as from a terminal: a test worker may run with Ctrl-C ignored, which a child inherits
                           preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    deadline = time.monotonic() + 60
    while not (out / "cells").exists() and time.monotonic() < deadline:
        time.sleep(0.2)
    time.sleep(3)  # the workers are training
    os.killpg(run.pid, signal.SIGINT)  # as a terminal does: the whole process group
    _, err = run.communicate(timeout=120)
    assert run.returncode == 130, err
    # the estimate printed before any work is not part of the interruption
    lines = [line for line in err.strip().splitlines() if line.strip() and not line.startswith("note:")]
    assert len(lines) == 1 and "interrupted" in lines[0] and "Traceback" not in err, err
    assert not (out / "config.json").exists() or check_outputs(out) == []


#: s a terminated worker may take to exit, and s between checks.
WORKER_EXIT_SECONDS = 10.0
POLL_SECONDS = 0.05


@pytest.mark.cli
def test_close_without_waiting_terminates_running_workers():
    executor = LocalExecutor(workers=2)
    executor.start()
    pool = executor._pool
    for _ in range(2):
        pool.submit(time.sleep, 60)
    time.sleep(1)
    processes = list(pool._processes.values())
    started = time.monotonic()
    executor.close(wait=False)
    # Poll rather than join: the pool's own management thread reaps the same processes, and a
    # join racing it can see the child gone before its exit code is recorded (is_alive() True).
    deadline = started + WORKER_EXIT_SECONDS
    while any(p.is_alive() for p in processes) and time.monotonic() < deadline:
        time.sleep(POLL_SECONDS)
    assert not any(p.is_alive() for p in processes), "workers still alive after close(wait=False)"
    assert time.monotonic() - started < WORKER_EXIT_SECONDS


def test_an_address_that_accepts_but_is_not_a_ray_head_is_one_error(monkeypatch):
    pytest.importorskip("ray")
    import ray

    from tableclean_suite.executors import ray_executor

    def refuse(**kwargs):
        raise ConnectionError("Failed to connect to Ray cluster at 10.0.0.9:6379\nmore lines")

    monkeypatch.setattr(ray_executor, "check_reachable", lambda address, timeout: None)
    monkeypatch.setattr(ray, "init", refuse)
    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    with pytest.raises(ClusterUnreachableError, match=r"'10\.0\.0\.9:6379': Failed to connect") as caught:
        RayExecutor(address="10.0.0.9:6379").start()
    assert "\n" not in str(caught.value)
