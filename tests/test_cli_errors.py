"""What used to end in a traceback or a silent surprise is one line and exit 2: unusable --out and
--plugins paths, plugins raising anything, a missing video extra, list flags given twice; and the
help texts read as text."""

import errno
import sys
from pathlib import Path

import pytest

from tableclean_suite.bench import cli, commands, plugins

LONG = "x" * 300  # one path component longer than any file system allows (ENAMETOOLONG)


def _one_line_exit_2(capsys, code, *needles):
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "Traceback" not in err[0], err
    assert all(needle in err[0] for needle in needles), err


@pytest.mark.parametrize("kind", [cli.DIRECTORY, cli.FILE])
def test_an_out_path_with_a_300_character_component_is_an_argument_error(tmp_path, kind):
    with pytest.raises(Exception) as caught:
        cli.output_path(kind)(str(tmp_path / LONG / "x"))
    assert type(caught.value).__name__ == "ArgumentTypeError" and "File name too long" in str(caught.value)


def test_an_unsearchable_parent_of_out_is_an_argument_error(monkeypatch):
    def denied(self):
        raise PermissionError(errno.EACCES, "Permission denied", str(self))

    monkeypatch.setattr(Path, "exists", denied)
    with pytest.raises(Exception, match="Permission denied") as caught:
        cli.output_path(cli.DIRECTORY)("locked/out")
    assert type(caught.value).__name__ == "ArgumentTypeError"


def test_scaling_with_a_too_long_out_is_one_line(tmp_path, capsys):
    code = commands.main(["scaling", "--out", str(tmp_path / LONG)])
    _one_line_exit_2(capsys, code, "--out", "File name too long")


def test_an_os_error_escaping_a_command_is_one_line_naming_the_path(monkeypatch, capsys):
    class Failing:
        @staticmethod
        def main(argv, prog):
            raise PermissionError(errno.EACCES, "Permission denied", "/somewhere/locked")

    monkeypatch.setattr(commands, "_module", lambda name: Failing)
    _one_line_exit_2(capsys, commands.main(["run"]), "/somewhere/locked", "Permission denied")


class Stop(BaseException):
    """Not an Exception: what a careless plugin may raise."""


@pytest.mark.parametrize("body", ["raise Stop()", "raise GeneratorExit()"])
def test_a_plugin_raising_a_base_exception_is_a_plugin_error(tmp_path, body):
    plugin = tmp_path / "bad_plugin.py"
    plugin.write_text(f"class Stop(BaseException):\n    pass\n{body}\n")
    with pytest.raises(plugins.PluginError, match="bad_plugin.py"):
        plugins.load_plugin(str(plugin))


def test_a_plugin_path_that_cannot_be_searched_is_a_plugin_error(monkeypatch):
    def denied(self):
        raise PermissionError(errno.EACCES, "Permission denied", str(self))

    monkeypatch.setattr(Path, "is_file", denied)
    with pytest.raises(plugins.PluginError, match="Permission denied"):
        plugins.load_plugin("locked/extras.py")


def test_a_plugin_file_name_too_long_is_one_line(capsys):
    code = commands.main(["scaling", "--plugins", f"{LONG}.py"])
    _one_line_exit_2(capsys, code, "--plugins", "File name too long")


def test_rollout_without_the_video_extra_stops_before_training(monkeypatch, capsys):
    from tableclean_suite.bench import rollout

    monkeypatch.setitem(sys.modules, "imageio", None)
    monkeypatch.setitem(sys.modules, "imageio.v2", None)
    monkeypatch.setattr(rollout, "train_policy", lambda *a, **k: pytest.fail("trained before checking imageio"))
    with pytest.raises(SystemExit) as stop:
        rollout.main(["--task", "paper", "--video", "out.mp4"])
    assert stop.value.code == 2 and "video extra" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["scaling", "--rewards", "r1", "--rewards", "r2"],
                                  ["scaling", "--segments=2", "--segments", "3"],
                                  ["run", "--rewards", "r1", "--rewards=r2"],
                                  ["scaling", "--plugins", "a.py", "--plugins", "b.py"]])
def test_a_list_flag_given_twice_is_refused_not_the_last_kept(argv, capsys):
    _one_line_exit_2(capsys, commands.main(argv), "given twice")


def test_help_texts_show_no_double_backticks():
    for name in ("run", "scaling", "tune", "interventions", "coverage"):
        text = commands.command_parser(name).format_help()
        assert "``" not in text, name


@pytest.mark.jit
def test_a_compilation_of_a_package_kernel_is_announced_once(capsys):
    import numba

    from tableclean_suite.bench import startup

    startup.announce_compiles()
    startup.announce_compiles()  # a second command in the same process: still one notice
    startup._NOTICE["said"] = False
    space = {"__name__": "tableclean_suite.first_contact"}
    exec("def twice(x):\n    return 2 * x\ndef thrice(x):\n    return 3 * x\n", space)
    assert numba.njit(space["twice"])(2) == 4 and numba.njit(space["thrice"])(2) == 6
    err = capsys.readouterr().err.splitlines()
    assert [line for line in err if "compiling kernels once" in line] == [err[0]], err


@pytest.mark.parametrize("flags", [["--segments", "40"],
                                   ["--fixed-plan-objects", "100"]])
def test_a_scaling_spec_the_task_model_refuses_is_one_line(flags, capsys, tmp_path):
    code = commands.main(["scaling", *flags, "--out", str(tmp_path)])
    _one_line_exit_2(capsys, code, "--segments/--objects")


def test_describe_fits_in_120_columns():
    from tableclean_suite.bench.describe import describe
    from tableclean_suite.task import TaskModel

    text = describe(TaskModel())
    assert max(map(len, text.splitlines())) <= 120 and "20 states = 18 non-terminal + 2 terminal" in text
