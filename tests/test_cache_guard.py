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


def test_the_guard_recompiles_after_a_dependency_changes(tmp_path):
    """A kernel cached against ``dep.value() == 1`` is compiled again once ``dep.py`` returns 2,
    though the kernel's own file is untouched."""
    (tmp_path / "main.py").write_text(MAIN)
    (tmp_path / "dep.py").write_text(DEPENDENCY.format(value=1))
    first = _run(tmp_path)
    (tmp_path / "dep.py").write_text(DEPENDENCY.format(value=2))  # main.py untouched
    assert (first, _run(tmp_path)) == ("10", "20")
