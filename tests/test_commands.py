"""``tableclean-bench COMMAND``: the registry, the shared options and their checks, in process (fast)."""

from __future__ import annotations

import argparse
import json

import pytest

from tableclean_suite.bench import cli, commands, plugins, speed

#: Every command with each shared option (the parsers say which they have).
PARSERS = commands.command_parsers()


def _commands_with(flag: str) -> list[str]:
    return [name for name, parser in PARSERS.items() if flag in parser._option_string_actions]


def _run(argv, capsys, prog="tableclean-bench"):
    """``commands.main(argv)``: its exit code and stderr's lines (robosuite's own log lines left out)."""
    code = commands.main(argv, prog=prog)
    err = [line for line in capsys.readouterr().err.splitlines() if not line.startswith("[robosuite")]
    return code, err


def test_every_registered_command_has_a_parser_with_the_shared_options():
    assert set(PARSERS) == set(commands.COMMANDS)
    for name, parser in PARSERS.items():
        assert isinstance(parser, cli.OneLineParser), name
        assert parser.prog == f"tableclean-bench {name}"
        assert {"--plugins", "--verbose", "-h"} <= set(parser._option_string_actions), name
        assert parser.format_help().startswith(f"usage: tableclean-bench {name}")


def test_shared_options_have_one_type_everywhere():
    for flag, kind in (("--seed", cli.non_negative_int), ("--workers", cli.positive_int),
                       ("--runs", cli.positive_int), ("--iterations", cli.positive_int)):
        users = [name for name in _commands_with(flag) if not (name == "run" and flag in ("--runs", "--iterations"))]
        assert len(users) >= 3, flag  # run's --runs/--iterations: checked by RunConfig with the other fields
        for name in users:
            assert PARSERS[name]._option_string_actions[flag].type is kind, (name, flag)
    for name in _commands_with("--out"):
        action = PARSERS[name]._option_string_actions["--out"]
        assert action.dest == "out" and action.type.__qualname__.startswith("output_path"), name


def test_the_top_level_parser_lists_every_command(capsys):
    assert commands.main(["--help"], prog="tableclean-bench") == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: tableclean-bench")
    for name in PARSERS:
        assert name in out
    sub = commands.build_parser()._subparsers._group_actions[0].choices
    assert set(sub) == set(PARSERS)
    assert "--seed" in sub["fidelity"].format_help()


def test_unknown_command_is_one_line_naming_the_commands(capsys):
    code, err = _run(["fidelty"], capsys)
    assert code == 2 and len(err) == 1
    assert err[0].startswith("tableclean-bench: error: unknown command 'fidelty'") and "fidelity" in err[0]


def test_flags_without_a_command_go_to_run_and_a_command_name_prefixes_the_usage(capsys):
    code, err = _run(["--rewards", "r9"], capsys)
    assert code == 2 and len(err) == 1 and err[0].startswith("tableclean-bench: error:") and "r9" in err[0]
    code, err = _run(["run", "--rewards", "r9"], capsys, prog="python -m tableclean_suite.bench")
    assert code == 2 and err[0].startswith("python -m tableclean_suite.bench run: error:")


def test_an_alias_names_the_old_entry_point(capsys):
    assert commands.run_alias("render", "python -m benchmarks.render_scene", ["--width", "0"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith("python -m benchmarks.render_scene: error: argument --width")


@pytest.mark.cli
def test_a_tiny_run_through_the_package_entry_point(tmp_path):
    import subprocess
    import sys

    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "tableclean_suite.bench", "run", "--learners", "q_learning",
                           "--rewards", "r4", "--runs", "3", "--iterations", "60", "--no-sweeps", "--no-literature",
                           "--no-figures", "--no-progress", "--out", str(out)], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads((out / "config.json").read_text())["args"]["runs"] == 3


@pytest.mark.cli
@pytest.mark.parametrize("name", ["tune", "pddl"])
def test_a_command_module_run_with_python_m_goes_through_the_dispatcher(name, tmp_path):
    import subprocess
    import sys

    module = commands.COMMANDS[name].module
    done = subprocess.run([sys.executable, "-m", module, "--seed", "-1"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300)
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and lines[0].startswith(f"python -m {module}: error:"), done.stderr


@pytest.mark.parametrize("name", _commands_with("--seed"))
def test_a_negative_seed_is_refused_before_any_work(name, capsys):
    code, err = _run([name, "--seed", "-1"], capsys)
    assert code == 2 and len(err) == 1
    assert err[0] == f"tableclean-bench {name}: error: argument --seed: expected an integer >= 0, got '-1'"


@pytest.mark.parametrize("name", _commands_with("--out"))
def test_an_empty_out_is_refused_before_any_work(name, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, err = _run([name, "--out", ""], capsys)
    assert code == 2 and len(err) == 1 and "argument --out" in err[0] and "empty" in err[0]
    assert list(tmp_path.iterdir()) == []  # nothing written into the working directory


@pytest.mark.parametrize("name", _commands_with("--out"))
def test_an_unusable_out_is_refused_before_any_work(name, capsys, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("keep me")
    directory = PARSERS[name]._option_string_actions["--out"].metavar == "DIR"
    target = blocker if directory else tmp_path  # a file where a folder goes, a folder where a file goes
    code, err = _run([name, "--out", str(target / "x") if directory else str(target)], capsys)
    assert code == 2 and len(err) == 1 and "argument --out" in err[0], err
    assert blocker.read_text() == "keep me"


@pytest.mark.parametrize("name", list(PARSERS))
@pytest.mark.parametrize("body, named", [("raise RuntimeError('no licence')\n", "RuntimeError: no licence"),
                                         ("import sys\nsys.exit(0)\n", "called sys.exit(0)")])
def test_a_plugin_that_raises_or_exits_is_one_line_naming_it(name, body, named, capsys, tmp_path):
    plugin = tmp_path / "bad_plugin.py"
    plugin.write_text(body)
    code, err = _run([name, "--plugins", str(plugin)], capsys)
    assert code == 2 and len(err) == 1
    assert "--plugins: plugin" in err[0] and "bad_plugin.py" in err[0] and named in err[0]


@pytest.mark.parametrize("argv, named", [
    (["--width", "0"], "--width"), (["--height", "-5"], "--height"), (["--width", "100000"], "--width"),
    (["--width", "wide"], "--width"), (["--out", "scene.jpg"], ".png")])
def test_render_refuses_bad_sizes_before_building_a_scene(argv, named, capsys, tmp_path):
    code, err = _run(["render", *argv], capsys)
    assert code == 2 and len(err) == 1 and named in err[0]


@pytest.mark.parametrize("argv, named", [
    (["--runs", "0"], "--runs"), (["--iterations", "0"], "--iterations"),
    (["--episodes", "0"], "--episodes"), (["--repeat", "0"], "--repeat"),
    (["--reward", "r9"], "--reward: invalid choice: 'r9'"), (["--sections", "learners,gpu"], "unknown section 'gpu'"),
    (["--sections", "skills", "--layout", "1", "9"], "--layout"), (["--sections", "skills", "--task", "nope"], "--task"),
])
def test_speed_refuses_zero_sized_and_unknown_inputs(argv, named, capsys):
    code, err = _run(["speed", *argv], capsys)
    assert code == 2 and len(err) == 1 and named in err[0], err


def test_speed_measures_the_sections_in_report_order_and_fails_with_a_failed_measurement(capsys, monkeypatch):
    ran = []

    def section(name, failed):
        return lambda args: ran.append(name) or speed.Section([speed.Table(name, [{"x": 1}])], failed)

    monkeypatch.setitem(speed.SECTION_RUNNERS, "cold-start", section("cold-start", False))
    monkeypatch.setitem(speed.SECTION_RUNNERS, "learners", section("learners", False))
    assert speed.main(["--sections", "cold-start,learners"]) == 0
    assert ran == ["learners", "cold-start"]
    monkeypatch.setitem(speed.SECTION_RUNNERS, "cold-start", section("cold-start", True))
    assert speed.main(["--sections", "cold-start"]) == 1


@pytest.mark.slow  # checking a robot name imports robosuite
def test_single_arm_commands_take_one_robot(capsys):
    code, err = _run(["fidelity", "--robots", "Panda,UR5e"], capsys)
    assert code == 2 and "give one robot" in err[-1]
    code, err = _run(["robots", "--robots", "Panda,Nao", "--episodes", "1"], capsys)
    assert code == 2 and "Nao" in err[-1] and "supported robots" in err[-1]


def test_output_path_type():
    directory, file = cli.output_path(cli.DIRECTORY), cli.output_path(cli.FILE)
    assert directory("results/x") == "results/x" and file("x.json") == "x.json"
    for parse, text in ((directory, ""), (directory, "  "), (file, "")):
        with pytest.raises(argparse.ArgumentTypeError):
            parse(text)


def test_plugin_executor_imports_the_plugins_in_spawned_workers(tmp_path):
    from tableclean_suite.executors import LocalExecutor
    from tableclean_suite.task import get_task_spec

    plugin = tmp_path / "spec_plugin.py"
    plugin.write_text("from tableclean_suite.task import TaskSpec, register_task_spec\n"
                      "register_task_spec(TaskSpec('plugin_worker_spec', segments=3), overwrite=True)\n")
    with plugins.with_plugins(LocalExecutor(workers=2), [str(plugin)]) as executor:
        specs = list(executor.map(get_task_spec, ["plugin_worker_spec", "paper"]))
    assert [spec.name for spec in specs] == ["plugin_worker_spec", "paper"] and specs[0].segments == 3
    assert plugins.with_plugins(LocalExecutor(workers=1), ()).__class__ is LocalExecutor  # nothing to wrap


#: A user's plugin module: an object type and a skill (MOVE, which logs each build to $PLUGIN_SKILL_LOG).
PHYSICS_PLUGIN = '''
import os

from robosuite.models.objects import BoxObject

from tableclean_suite.controllers import register_skill
from tableclean_suite.controllers.move import MoveSkill
from tableclean_suite.environments import register_object

register_object("plugin_cube", lambda name: BoxObject(name=name, size=[0.02, 0.02, 0.02], rgba=[0.9, 0.8, 0.1, 1]),
                description="a 4 cm cube from a plugin", overwrite=True)


class LoggedMove(MoveSkill):
    def build(self, info):
        with open(os.environ["PLUGIN_SKILL_LOG"], "a") as handle:
            handle.write("move\\n")
        return super().build(info)


register_skill("move", LoggedMove, replace=True)
'''
#: Each physics command on a tiny budget with the plugin's object (fidelity's rounds in two spawned workers),
#: and how it refuses the object without the plugin.
TASK = ["--task", "cube_task.json"]
PHYSICS_COMMANDS = {
    "demos": ([*TASK, "--episodes", "1", "--out", "demos.hdf5"], "unknown object_type 'plugin_cube'"),
    "fidelity": ([*TASK, "--trials", "2", "--actions", "move", "--workers", "2", "--quiet", "--out", "fidelity"],
                 "unknown object_type 'plugin_cube'"),
    "rollout": ([*TASK, "--iterations", "300", "--runs", "1", "--max-actions", "2", "--width", "64", "--height", "64",
                 "--frame-every", "20", "--out", "rollout.gif"], "unknown object_type 'plugin_cube'"),
    "objects": (["--objects", "plugin_cube", "--settings", "alone", "--episodes", "1", "--quiet", "--out", "objects"],
                "unknown object type 'plugin_cube'"),
}


@pytest.mark.slow
@pytest.mark.cli
@pytest.mark.parametrize("name", list(PHYSICS_COMMANDS))
def test_a_plugins_object_type_and_skill_reach_the_physics_commands(name, tmp_path):
    """demos, fidelity, rollout and objects see a plugin's object type and run its skill."""
    import os
    import subprocess
    import sys

    (tmp_path / "my_objects.py").write_text(PHYSICS_PLUGIN)
    (tmp_path / "cube_task.json").write_text(json.dumps({"name": "plugin_cube_task", "segments": 2,
                                                         "objects": ["plugin_cube"]}))
    log = tmp_path / "skill.log"
    env = {**os.environ, "PLUGIN_SKILL_LOG": str(log), "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}

    argv, refusal = PHYSICS_COMMANDS[name]

    def command(*extra):
        return subprocess.run([sys.executable, "-m", "tableclean_suite.bench", name, *extra, *argv], cwd=tmp_path,
                              env=env, capture_output=True, text=True, timeout=600)

    refused = command()
    assert refused.returncode == 2 and refusal in refused.stderr, refused.stderr
    done = command("--plugins", "my_objects.py")
    assert done.returncode == 0, done.stdout + done.stderr
    assert log.read_text().count("move") >= 1  # the plugin's skill ran (in the workers, for fidelity)


@pytest.mark.slow
def test_render_refuses_a_camera_the_scene_lacks_naming_those_it_has(capsys, tmp_path):
    code, err = _run(["render", "--camera", "ceiling", "--width", "32", "--height", "32",
                      "--out", str(tmp_path / "scene.png")], capsys)
    assert code == 2 and len(err) == 1, err
    assert "--camera: unknown camera 'ceiling'" in err[0] and "tableview" in err[0] and "frontview" in err[0]
    assert not (tmp_path / "scene.png").exists()
    assert _run(["render", "--camera", "frontview", "--width", "32", "--height", "32",
                 "--out", str(tmp_path / "scene.png")], capsys)[0] == 0
    assert (tmp_path / "scene.png").read_bytes().startswith(b"\x89PNG")


def test_a_command_whose_module_is_missing_is_one_line(capsys, monkeypatch):
    monkeypatch.setitem(commands.COMMANDS, "ghost", commands.Command("tableclean_suite.bench.no_such_module", "gone"))
    code, err = _run(["ghost"], capsys)
    assert code == 2 and err == ["tableclean-bench: error: command 'ghost' is not available in this installation "
                                 "(tableclean_suite.bench.no_such_module is missing)"]
    assert "ghost" not in commands.command_parsers()


def test_plugin_files_are_kept_as_absolute_paths_for_workers_elsewhere(tmp_path, monkeypatch):
    from pathlib import Path

    monkeypatch.chdir(tmp_path)
    args = cli.command_parser("x", "y").parse_args(["--plugins", "extras.py, my_package.objects,extras.py"])
    assert args.plugins == (str(tmp_path / "extras.py"), "my_package.objects")
    assert Path(args.plugins[0]).is_absolute()


@pytest.mark.parametrize("raised, code, line", [
    (SystemExit(3), 3, None), (SystemExit("stopped: a message"), 1, "stopped: a message"),
    (KeyboardInterrupt(), commands.EXIT_INTERRUPTED, "{prog}: interrupted"),
    ("resource", 2, "{prog}: error: too big for the test"),
])
def test_the_command_line_and_the_old_entry_points_end_a_command_alike(raised, code, line, capsys, monkeypatch):
    import sys
    import types

    from tableclean_suite.resources import ResourceError

    module = types.ModuleType("tableclean_faults_fake_command")

    def main(argv=None, prog=None):
        raise ResourceError("too big for the test") if raised == "resource" else raised

    module.main = main
    monkeypatch.setitem(sys.modules, module.__name__, module)
    monkeypatch.setitem(commands.COMMANDS, "fake", commands.Command(module.__name__, "a test command"))
    # an entry point ignores Ctrl-C after an interrupt; this process (and the processes it starts) must not
    monkeypatch.setattr(commands.signal, "signal", lambda *args: None)
    assert _run(["fake"], capsys) == (code, [] if line is None else [line.format(prog="tableclean-bench fake")])
    assert commands.run_alias("fake", "python -m benchmarks.fake") == code
    err = capsys.readouterr().err.splitlines()
    assert err == ([] if line is None else [line.format(prog="python -m benchmarks.fake")])


def test_an_old_entry_point_of_a_missing_command_is_one_line(capsys, monkeypatch):
    monkeypatch.setitem(commands.COMMANDS, "ghost", commands.Command("tableclean_suite.bench.no_such_module", "gone"))
    assert commands.run_alias("ghost", "python -m benchmarks.ghost") == 2
    assert capsys.readouterr().err.splitlines() == [
        "python -m benchmarks.ghost: error: command 'ghost' is not available in this installation "
        "(tableclean_suite.bench.no_such_module is missing)"]
