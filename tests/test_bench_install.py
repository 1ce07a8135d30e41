"""A plain (non-editable) install ships every command: ``tableclean-bench COMMAND`` (the console script)
and ``python -m tableclean_suite.bench COMMAND`` run from a directory outside the checkout, without network."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.install

ROOT = Path(__file__).resolve().parents[1]
SOURCES = ("setup.py", "README.md", "tableclean_suite")
TINY = ["--runs", "5", "--iterations", "100", "--no-sweeps", "--no-figures", "--no-progress"]


def _can_build_wheels() -> bool:
    """Whether setuptools can build a wheel offline here (setuptools >= 70.1, or the wheel package)."""
    import importlib.util

    from setuptools import __version__ as setuptools_version

    major, minor = (int(part) for part in setuptools_version.split(".")[:2])
    return (major, minor) >= (70, 1) or importlib.util.find_spec("wheel") is not None


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """``pip install --no-deps --no-build-isolation --target SITE`` of a copy of the checkout
    (built from a copy so that the build leaves nothing in the checkout)."""
    # the dev extra installs 'wheel', so this holds wherever the README's set-up ran; no silent skip
    assert _can_build_wheels(), "pip cannot build the wheel offline: install the dev extra (it brings 'wheel')"
    base = tmp_path_factory.mktemp("install")
    source, site = base / "source", base / "site"
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, source / name, ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
        else:
            source.mkdir(exist_ok=True)
            shutil.copy(ROOT / name, source / name)
    result = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index", "--quiet",
         "--target", str(site), str(source)],
        capture_output=True, text=True, timeout=600,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    elsewhere = base / "elsewhere"  # the working directory: neither the checkout nor the install
    elsewhere.mkdir()
    env = {**os.environ, "PYTHONPATH": str(site), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return site, elsewhere, env


def _check_outputs(out: Path, site: Path, env, cwd):
    for name in ("table3.csv", "table4.csv", "curves.csv"):
        assert (out / name).stat().st_size > 0, name
    manifest = json.loads((out / "config.json").read_text())
    assert manifest["args"]["runs"] == 5
    assert sorted(manifest["files"]) == ["comparisons.csv", "curves.csv", "table3.csv", "table4.csv"]
    check = subprocess.run(
        [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(ROOT / 'tests')!r}); "
         f"from publication_check import check_outputs; sys.exit(len(check_outputs({str(out)!r})))"],
        cwd=cwd, env=env, capture_output=True, text=True, timeout=120,
    )
    assert check.returncode == 0, check.stderr


def test_module_runs_from_the_installed_package(installed):
    site, elsewhere, env = installed
    where = subprocess.run([sys.executable, "-c", "import tableclean_suite.bench.run as r; print(r.__file__)"],
                           cwd=elsewhere, env=env, capture_output=True, text=True, timeout=120)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(site)  # not the checkout
    out = elsewhere / "out_module"
    result = subprocess.run([sys.executable, "-m", "tableclean_suite.bench.run", *TINY, "--out", str(out)],
                            cwd=elsewhere, env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    assert "Table 3" in result.stdout and "Table 4" in result.stdout
    _check_outputs(out, site, env, elsewhere)


def test_console_script_runs_from_the_installed_package(installed):
    site, elsewhere, env = installed
    script = site / "bin" / "tableclean-bench"
    assert script.is_file()
    out = elsewhere / "out_script"
    result = subprocess.run([sys.executable, str(script), *TINY, "--out", str(out)], cwd=elsewhere, env=env,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    _check_outputs(out, site, env, elsewhere)
    usage = subprocess.run([sys.executable, str(script), "--rewards", "r9"], cwd=elsewhere, env=env,
                           capture_output=True, text=True, timeout=120)
    assert usage.returncode == 2 and usage.stderr.startswith("tableclean-bench: error:") and "r9" in usage.stderr


def test_every_command_helps_through_the_installed_console_script(installed):
    site, elsewhere, env = installed
    script = site / "bin" / "tableclean-bench"
    listing = subprocess.run([sys.executable, str(script), "--help"], cwd=elsewhere, env=env, capture_output=True,
                             text=True, timeout=120)
    assert listing.returncode == 0 and listing.stdout.startswith("usage: tableclean-bench"), listing.stderr
    # every command's --help in one process of the installed package (one interpreter start, not thirteen)
    code = ("import contextlib, io, sys\n"
            "from tableclean_suite.bench import commands\n"
            "for name in commands.command_parsers():\n"
            "    text = io.StringIO()\n"
            "    with contextlib.redirect_stdout(text):\n"
            "        assert commands.main([name, '--help'], prog='tableclean-bench') == 0, name\n"
            "    assert text.getvalue().startswith(f'usage: tableclean-bench {name}'), name\n"
            "    print(name)\n")
    helped = subprocess.run([sys.executable, "-c", code], cwd=elsewhere, env=env, capture_output=True, text=True,
                            timeout=300)
    assert helped.returncode == 0, helped.stderr
    names = helped.stdout.split()
    assert {"run", "scaling", "tune", "fidelity", "demos", "render", "robots", "speed"} <= set(names)
    for name in names:
        assert name in listing.stdout


def test_a_second_command_runs_through_the_installed_console_script(installed):
    site, elsewhere, env = installed
    script = site / "bin" / "tableclean-bench"
    result = subprocess.run([sys.executable, str(script), "run", "--task", "three_segments", "--describe"],
                            cwd=elsewhere, env=env, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    assert "spec='three_segments'" in result.stdout and "Exact success probability" in result.stdout
