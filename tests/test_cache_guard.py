"""numba's disk cache must not serve a kernel compiled against an older version of a module it calls."""

import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

DEPENDENCY = "import numba\n\n@numba.njit(cache=True)\ndef value():\n    return {value}\n"
MAIN = textwrap.dedent("""
    import numba
    import dep

    @numba.njit(cache=True)
    def kernel():
        return dep.value() * 10

    if {guarded}:
        from tableclean_suite.learners import cache_guard
        cache_guard.guard("test", [kernel, dep.value], [dep])
    print(kernel())
""")


def _run(folder: Path) -> str:
    env_path = f"{folder}:{ROOT}"
    # no .pyc: Python validates one by the source's whole-second mtime and size, so a rewrite within
    # the same second would run stale bytecode and the test would measure Python, not numba
    env = {"PYTHONPATH": env_path, "PATH": "/usr/bin:/bin", "PYTHONDONTWRITEBYTECODE": "1"}
    result = subprocess.run([sys.executable, str(folder / "main.py")], cwd=folder, capture_output=True, text=True,
                            env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    return result.stdout.strip()


def _scenario(tmp_path: Path, guarded: bool) -> tuple[str, str]:
    folder = tmp_path / ("guarded" if guarded else "plain")
    folder.mkdir()
    (folder / "main.py").write_text(MAIN.format(guarded=guarded))
    (folder / "dep.py").write_text(DEPENDENCY.format(value=1))
    first = _run(folder)
    (folder / "dep.py").write_text(DEPENDENCY.format(value=2))  # main.py untouched
    return first, _run(folder)


def test_numba_alone_serves_a_stale_kernel(tmp_path):
    """The hazard the guard exists for (if numba ever fixes it, this test says so)."""
    assert _scenario(tmp_path, guarded=False) == ("10", "10")


def test_the_guard_recompiles_after_a_dependency_changes(tmp_path):
    assert _scenario(tmp_path, guarded=True) == ("10", "20")
