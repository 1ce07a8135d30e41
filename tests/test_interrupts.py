"""Ctrl-C ends every command with one line and exit 130: during imports, training, figure drawing
in forked processes (which stop quietly, never waited for) and tune (its finished trials published)."""

import importlib
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tableclean_suite.bench import commands, startup
from publication_check import check_outputs

ROOT = Path(__file__).resolve().parents[1]


def test_ctrl_c_while_a_command_module_is_imported_is_one_line(monkeypatch, capsys):
    def interrupted_import(name):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as error:  # what Python makes of Ctrl-C inside a class body being created
            raise RuntimeError("Error calling __set_name__ on '_Field' instance 'id' in 'EnvSpec'") from error

    monkeypatch.setattr(commands, "_module", interrupted_import)
    assert commands.main(["run"]) == commands.EXIT_INTERRUPTED
    assert capsys.readouterr().err.strip().splitlines() == ["tableclean-bench run: interrupted"]


def _import_swallowing_ctrl_c(folder: Path, name: str) -> None:
    """Import a module that raises SIGINT inside ``try/except BaseException: pass`` (as an extension module's
    initialisation clears a ``KeyboardInterrupt`` raised in its Python callbacks, e.g. Cython's ``abc.register``)."""
    (folder / f"{name}.py").write_text(
        "import signal\ntry:\n    signal.raise_signal(signal.SIGINT)\nexcept BaseException:\n    pass\nDONE = True\n")
    sys.path.insert(0, str(folder))
    try:
        importlib.import_module(name)
    finally:
        sys.path.remove(str(folder))
    assert sys.modules[name].DONE  # the import itself ran to its end


@pytest.mark.parametrize("block_goes_on", [True, False])
def test_a_ctrl_c_an_import_swallows_is_raised_after_the_import_or_at_the_blocks_end_and_only_once(tmp_path,
                                                                                                 block_goes_on):
    if signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        pytest.skip("Ctrl-C does not have Python's default handler in this process")
    with pytest.raises(KeyboardInterrupt):
        with startup.catch_ctrl_c():
            _import_swallowing_ctrl_c(tmp_path, f"swallowing_module_{block_goes_on}")
            if block_goes_on:
                time.sleep(5)
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    time.sleep(3 * startup.CTRL_C_RETRY_SECONDS)  # no second, late KeyboardInterrupt outside the block


def test_ctrl_c_while_the_package_itself_is_imported_is_one_line(monkeypatch, capsys):
    import tableclean_bench

    class InterruptedImport:
        def find_spec(self, name, path=None, target=None):
            if name == "tableclean_suite.bench.commands":
                raise KeyboardInterrupt
            return None

    monkeypatch.delitem(sys.modules, "tableclean_suite.bench.commands")
    monkeypatch.setattr(sys, "meta_path", [InterruptedImport(), *sys.meta_path])
    monkeypatch.setattr(signal, "signal", lambda *args: None)  # the script ignores further Ctrl-C; not here
    assert tableclean_bench.main() == 130
    assert capsys.readouterr().err.strip().splitlines() == ["tableclean-bench: interrupted"]


def test_other_runtime_errors_still_surface(monkeypatch):
    def failing(name):
        raise RuntimeError("a real bug")

    monkeypatch.setattr(commands, "_module", failing)
    with pytest.raises(RuntimeError, match="a real bug"):
        commands.main(["run"])


@pytest.mark.cli
@pytest.mark.parametrize("delay", [0.05, 0.3, 1.0])
def test_ctrl_c_early_in_a_command_is_one_line_and_exit_130(tmp_path, delay):
    """From the moment the package is imported: the command's own imports, parsing, the start of work.
    (Not at once after "ready": between that line and the call of ``main`` only this test's own
    one-line script runs, which handles no Ctrl-C.)"""
    argv = ["scaling", "--segments", "2", "--objects", "1", "--fixed-plan-objects", "none", "--out", str(tmp_path)]
    process = subprocess.Popen([sys.executable, "-c", "import sys; from tableclean_suite.bench.commands import main; "
                                f"print('ready', flush=True); sys.exit(main(prog='tableclean-bench', argv={argv!r}))"],
                               cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))  # as a terminal
    assert process.stdout.readline().strip() == "ready"
    time.sleep(delay)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130 and "Traceback" not in err, err
    assert err.strip().splitlines() == ["tableclean-bench scaling: interrupted"], err


def test_ctrl_c_during_tune_publishes_the_finished_trials_and_exits_130(tmp_path, monkeypatch, capfd):
    import json

    from tableclean_suite.bench import tune

    made = []

    class InterruptedEvaluation(tune.Evaluation):
        def __init__(self, *args, **kwargs):
            made.append(1)
            if len(made) == 4:  # the paper reference, two trials, then Ctrl-C in the third
                raise KeyboardInterrupt
            super().__init__(*args, **kwargs)

    monkeypatch.setattr(tune, "Evaluation", InterruptedEvaluation)
    out = tmp_path / "tune"
    code = tune.main(["--runs", "4", "--iterations", "200", "--trials", "5", "--out", str(out)])
    err = capfd.readouterr().err
    assert code == 130 and "Traceback" not in err and len(err.strip().splitlines()) == 1, err
    assert json.loads((out / "best.json").read_text())["completed"] == 2
    assert check_outputs(out) == []


@pytest.mark.cli
def test_ctrl_c_while_numba_compiles_ends_the_process_in_one_line(tmp_path):
    """Raised inside a compilation, KeyboardInterrupt can land in an llvmlite ctypes callback that
    prints it as ignored and goes on; during a compilation Ctrl-C exits at once instead."""
    code = ("import os, signal, time\n"
            "import numba\n"
            "from tableclean_suite.bench import startup\n"
            "startup.announce_compiles('tableclean-bench run')\n"
            "startup._compiling(True)\n"  # what numba's compile event does at a compilation's start
            "os.kill(os.getpid(), signal.SIGINT)\n"
            "time.sleep(5)\n"
            "print('went on')\n")
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 130 and "went on" not in done.stdout
    assert done.stderr.strip().splitlines() == ["tableclean-bench run: interrupted"]


def test_the_interrupt_handler_is_only_swapped_during_a_compilation():
    from tableclean_suite.bench import startup

    before = signal.getsignal(signal.SIGINT)
    startup._compiling(True)
    startup._compiling(True)  # nested
    startup._compiling(False)
    during = signal.getsignal(signal.SIGINT)
    startup._compiling(False)
    assert signal.getsignal(signal.SIGINT) is before
    assert during is (startup._interrupted_while_compiling if before is signal.default_int_handler else before)
