"""Test configuration: headless MuJoCo rendering before robosuite is imported, and the test tiers.

Markers (registered in pytest.ini): ``slow`` (MuJoCo physics, full-size runs), ``cli`` (a command
line in a new process), ``install`` (pip builds and installs the package), ``ray`` (a local Ray
cluster), ``jit`` (compiles a numba kernel no disk cache serves).  Test files mark ``slow``
themselves; the others are given here, from :data:`HEAVY_TESTS`, so one table says which tests
leave the process or compile.  Every test that carries none
of them is marked ``quick``: ``python -m pytest -m quick`` is the development tier (at most 2 minutes
on 2 cores from an empty numba cache), and ``python -m pytest`` still runs everything.  (A test file may also mark its own tests, as
tests/test_docs.py does per code block.)

Both run on one pytest-xdist worker per core (``-n auto`` in pytest.ini; ``-n 0`` runs in this
process): tests grouped by file, the ``ray`` tests all on one worker (:data:`SERIAL_GROUPS`).

The quick tier stays quick: in a run that selects it (``-m quick``), a ``quick`` test that starts a
process (``subprocess``, so also pip, Ray or a command line) fails, naming the command and the
markers to give it; a process a library starts while it is being imported is allowed.  The full
run does not check this, so a test not yet classified never fails CI for it.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy.testing  # noqa: F401  (runs `lscpu` once on import; numba's first cached kernel imports it)
import pytest

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering without a display (osmesa also works where installed)

#: Markers that keep a test out of the quick tier.
HEAVY_MARKERS = ("slow", "cli", "install", "ray", "jit")

#: Marker -> tests that carry it: a test file ("test_cli.py": all its tests), one test
#: ("test_demos.py::test_bad_policy_exits_2", every parametrised id) or one of its ids ("...[id]").
HEAVY_TESTS: dict[str, tuple[str, ...]] = {
    "cli": (
        "test_bench_cache.py",
        "test_bench_config.py::test_help_lists_the_allowed_names",
        "test_bench_config.py::test_bad_names_exit_2_with_the_allowed_ones",
        "test_bench_derived.py::test_warm_fresh_and_empty_caches_write_identical_files_and_tables",
        "test_bench_derived.py::test_a_changed_setting_is_not_served_from_the_caches",
        "test_bench_outputs.py::test_unusable_out_exits_2_before_training",
        "test_bench_outputs.py::test_cli_outputs_agree_with_their_manifest",
        "test_bench_window.py::test_window_invariance_entry_point_exits_2_without_a_traceback",
        "test_cache_guard.py",
        "test_demos.py::test_bad_flag_from_the_command_line_has_no_traceback",
        "test_examples.py",
        "test_executors.py::test_cells_through_an_executor_are_bit_identical_to_the_serial_run",
        "test_gym_envs.py::test_import_does_not_load_the_physics_env",
        "test_gym_envs.py::test_record_video_writes_an_episode_with_the_video_extra",  # ffmpeg
        "test_learners_spec.py::test_second_process_uses_the_numba_disk_cache",
        "test_package.py",
        "test_speed.py::test_a_timed_process_runs_this_package",
        # the page's machine stamp asks the platform for the processor, which runs `uname -p`
        "test_speed.py::test_the_page_is_stamped_with_the_machine_and_marks_a_failed_section",
        "test_speed.py::test_the_command_writes_the_page_it_printed",
    ),
    "install": ("test_bench_install.py",),
    "ray": (
        "test_executors.py::test_ray_gives_the_local_results",
        "test_executors.py::test_ray_retries_a_task_that_fails_once",
        "test_executors.py::test_ray_raises_naming_a_task_that_keeps_failing",
        "test_executors.py::test_cells_through_an_executor_are_bit_identical_to_the_serial_run",
        "test_physics_backend.py::test_physics_runs_on_ray_equal_the_runs_in_this_process",
    ),
    "jit": (  # a user's learner gets its own compiled copy of the training loop, which no disk cache serves
        "test_learners.py::test_user_defined_learner_object_and_registration",
        "test_learners.py::test_compiled_records_have_the_same_bits_for_any_thread_count[user_learner]",
        "test_learners_extra.py::test_a_user_target_with_the_trace_rule_gets_the_same_numbers",
        "test_learners_spec.py::test_user_learner_gets_its_own_compiled_loop_with_the_same_numbers",
        # the compiled control loop and the operational-space kernels: no other quick test compiles them
        # (a minute or more of a cold start)
        "test_fast_control.py",
    ),
}

#: Marker -> pytest-xdist group: the tests carrying the marker run one after the other on one
#: worker (``--dist loadgroup`` in pytest.ini).  Each ``ray`` test starts its own local Ray, and two
#: at once on one machine would compete for its ports and its 2 cores' worker slots.  Every other
#: test is grouped with its file, so a module's fixtures (a physics env, a trained grid) are built by
#: one worker only: the quick tier took 77 s on 2 workers with the tests spread one by one, 45 s
#: grouped by file, 70 s in one process.
SERIAL_GROUPS: dict[str, str] = {"ray": "ray"}


def _table_marker(nodeid: str) -> list[str]:
    """The markers :data:`HEAVY_TESTS` gives the test ``nodeid`` (``tests/test_x.py::test_y[id]``)."""
    path, _, name = nodeid.partition("::")
    file = path.rsplit("/", 1)[-1]
    function = name.split("[", 1)[0]
    return [marker for marker, entries in HEAVY_TESTS.items()
            if file in entries or f"{file}::{function}" in entries or f"{file}::{name}" in entries]


@pytest.hookimpl(tryfirst=True)  # before pytest's own -m selection reads the markers
def pytest_collection_modifyitems(config, items):
    """Give the tests of :data:`HEAVY_TESTS` their markers, then mark every other test ``quick``."""
    modules = {}
    for item in items:
        for marker in _table_marker(item.nodeid):
            item.add_marker(getattr(pytest.mark, marker))
        if not any(item.get_closest_marker(name) for name in HEAVY_MARKERS):
            item.add_marker(pytest.mark.quick)
        groups = [group for marker, group in SERIAL_GROUPS.items() if item.get_closest_marker(marker) is not None]
        item.add_marker(pytest.mark.xdist_group(groups[0] if groups else item.nodeid.partition("::")[0]))
        if getattr(item, "module", None) is not None:
            modules[item.nodeid.partition("::")[0].rsplit("/", 1)[-1]] = item.module
    here = Path(__file__).parent
    stale = [entry for entries in HEAVY_TESTS.values() for entry in entries
             if not (here / entry.split("::")[0]).exists()
             or ("::" in entry and entry.split("::")[0] in modules
                 and not hasattr(modules[entry.split("::")[0]], entry.split("::")[1].split("[")[0]))]
    if stale:
        raise pytest.UsageError(f"tests/conftest.py HEAVY_TESTS names tests that do not exist: {', '.join(stale)}")


class _ProcessInQuickTest(RuntimeError):
    pass


def _importing() -> bool:
    """Whether the caller runs inside an import (a library probing its environment as it loads:
    glfw starts a Python process to read its library's version)."""
    frame = sys._getframe(2)
    while frame is not None:
        if frame.f_code.co_filename.startswith("<frozen importlib"):
            return True
        frame = frame.f_back
    return False


def _refuse_processes(nodeid: str):
    original = subprocess.Popen.__init__

    def refuse(self, args, *rest, **kwargs):
        if _importing():
            return original(self, args, *rest, **kwargs)
        shown = " ".join(map(str, args)) if isinstance(args, (list, tuple)) else str(args)
        raise _ProcessInQuickTest(f"{nodeid} is a quick test but starts a process ({shown[:120]}); "
                                  "give it a marker in tests/conftest.py HEAVY_TESTS (cli, install or ray)")

    subprocess.Popen.__init__ = refuse
    return original


def _quick_selected(config) -> bool:
    """Whether this run selects the quick tier (``-m quick``, or an expression naming it)."""
    return "quick" in (config.getoption("markexpr") or "")


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item):
    """In a quick-tier run, a quick test's fixtures may not start processes."""
    return (yield from _guarded(item))


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    """Nor may the test itself."""
    return (yield from _guarded(item))


def _guarded(item):
    if item.get_closest_marker("quick") is None or not _quick_selected(item.config):
        return (yield)
    original = _refuse_processes(item.nodeid)
    try:
        return (yield)
    finally:
        subprocess.Popen.__init__ = original
