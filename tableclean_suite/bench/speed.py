"""``tableclean-bench speed``: how fast the learners, the skills and a first run are on this machine.

    tableclean-bench speed                                    # every section (a few minutes)
    tableclean-bench speed --sections learners,skills         # some of them
    tableclean-bench speed --markdown docs/measurements.md    # also write them as a page stamped with the machine

Every figure is measured in this run; where there is a yardstick it is a ratio to it, measured
alongside (ratios of neighbouring measurements drift much less with the load than seconds).
``learners``: every learner's updates per second relative to Q-learning's, and the compiled learners
against the step-at-a-time loop; ``skills``: control steps per second of robosuite's ``env.step``, the
compiled control path and raw MuJoCo; ``cold-start``: the run command in fresh processes from an empty
numba cache.  Each table's note says how it was measured.

Exit code 0; 1 when a measurement failed (a process exited non-zero, an episode did not end
terminal); 2 on bad flags.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
import timeit
from dataclasses import dataclass
from pathlib import Path

from tableclean_suite.bench import cli

PROG = "tableclean-bench speed"
SECTIONS = ("learners", "skills", "cold-start")
#: Learners compared with the step-at-a-time loop, which trains ``--runs`` / `PLAIN_LOOP_SHARE` runs (>= 1).
PLAIN_LOOP_LEARNERS = ("q_learning", "sarsa")
PLAIN_LOOP_SHARE = 50
#: The command ``cold-start`` times (``--out DIR`` appended) and its processes: (label, DIR).
COLD_START_COMMAND = ("-m", "tableclean_suite.bench", "run", "--no-progress")
COLD_START_PROCESSES = (("first process (empty numba cache)", "run1"),
                        ("second process, same output folder", "run1"),
                        ("second process, new output folder", "run2"))
#: Package versions stamped on the Markdown page.
VERSIONED = ("numba", "numpy", "mujoco", "robosuite")


@dataclass(frozen=True)
class Table:
    """One table of the report: a one-line ``title``, ``rows`` (dicts of formatted values), a ``note``."""

    title: str
    rows: list
    note: str = ""

    def text(self) -> str:
        """The table as plain text."""
        import pandas as pd

        return "\n".join(filter(None, [self.title, pd.DataFrame(self.rows).to_string(index=False), self.note]))

    def markdown(self) -> str:
        """The table as Markdown, its title a level-3 heading."""
        return "\n\n".join(filter(None, [f"### {self.title}", cli.markdown_table(self.rows), self.note]))


@dataclass(frozen=True)
class Section:
    """A section's tables, and whether its measurement failed."""

    tables: list
    failed: bool = False


def _millions(per_second: float) -> str:
    """A rate in millions per second, three significant digits below 100."""
    millions = per_second / 1e6
    return f"{millions:#.3g}" if millions < 100 else f"{millions:.0f}"


def learner_table(reward: str, runs: int, iterations: int, repeat: int) -> Table:
    """Every registered learner's updates per second on the paper spec and its time per update relative
    to Q-learning's; Dyna-Q's planning updates counted apart."""
    from tableclean_suite.learners import get_learner, learner_names, train

    seconds = {}
    for name in learner_names():
        train(name, reward, runs=2, iterations=10)  # warm-up: compile or load the kernel
        seconds[name] = min(timeit.repeat(lambda: train(name, reward, runs=runs, iterations=iterations),
                                          repeat=repeat, number=1))
    real = runs * iterations
    rows = [{"learner": name, "M updates/s": _millions(real / elapsed),
             "planning M updates/s": _millions(real * get_learner(name).planning_steps / elapsed),
             "time per update / Q-learning's": f"{elapsed / seconds['q_learning']:.2f}"}
            for name, elapsed in seconds.items()]
    return Table(f"Learners: paper spec, reward {reward}", rows,
                 f"{runs} runs x {iterations} iterations per train() call, the fastest of {repeat} (wall clock, "
                 "all cores, records included); a real update is one environment step and its TD update.")


def plain_loop_table(runs: int, iterations: int, repeat: int) -> Table:
    """`PLAIN_LOOP_LEARNERS` compiled against the step-at-a-time loop, updates per second (reward r2)."""
    from tableclean_suite.learners import train

    plain_runs = max(1, runs // PLAIN_LOOP_SHARE)
    rows = []
    for learner in PLAIN_LOOP_LEARNERS:
        train(learner, "r2", runs=2, iterations=10)
        compiled, plain = (n * iterations / min(timeit.repeat(
            lambda: train(learner, "r2", runs=n, iterations=iterations, engine=engine), repeat=repeat, number=1))
            for engine, n in (("compiled", runs), ("reference", plain_runs)))
        rows.append({"learner": learner, "compiled M updates/s": _millions(compiled),
                     "step-at-a-time M updates/s": _millions(plain),
                     "compiled / step-at-a-time": f"{compiled / plain:.0f}"})
    return Table("Compiled learners against the step-at-a-time loop", rows,
                 "Step-at-a-time loop (train(engine=\"reference\"), one step per Python call, the same arrays): "
                 f"{plain_runs} runs x {iterations} iterations; the fastest of the repeats on both sides.")


def learners_section(args) -> Section:
    """Every learner against Q-learning; the compiled learners against the plain loop."""
    return Section([learner_table(args.reward, args.runs, args.iterations, args.repeat),
                    plain_loop_table(args.runs, args.iterations, args.repeat)])


def run_episode(env, record_states: bool = False) -> tuple[dict, list]:
    """Reset ``env`` and execute the task model's shortest plan with the skills.

    Returns:
        ``({"steps", "wall_s", "env_s", "terminal"}, states)``: control steps, wall seconds, seconds inside
        the stepping, whether it ended terminal; with ``record_states`` the mjData state at the start of
        every control step, else ``[]``.

    Raises:
        ValueError: ``record_states`` on an env without the compiled path's stepper.
    """
    from tableclean_suite.controllers import SkillController
    from tableclean_suite.controllers.fast_control import ControlStepLog, fast_stepper_of

    stepper = fast_stepper_of(env)
    if record_states:
        if stepper is None:
            raise ValueError("recording the control steps' states needs the compiled path's stepper "
                             "(make_skill_env(fast_control=True))")
        stepper.state_log = ControlStepLog(stepper)
    controller = SkillController(env, env.task_model)
    env.reset()
    start = time.perf_counter()
    results = controller.execute_plan(env.task_model.shortest_plan(env.symbolic_state()))
    episode = {"steps": sum(r.steps for r in results), "wall_s": time.perf_counter() - start,
               "env_s": sum(r.env_time for r in results),
               "terminal": bool(results and results[-1].state_after is not None
                                and results[-1].state_after.is_terminal)}
    if not record_states:
        return episode, []
    states, stepper.state_log = stepper.state_log.states(), None
    return episode, states


def replay_mujoco(env, states: list) -> float:
    """Seconds of the raw ``mj_step`` calls of one control step from each of ``states``, on a copy of the data."""
    import mujoco

    from tableclean_suite.robosuite_adapter import mj_model

    model = mj_model(env.sim)
    data = mujoco.MjData(model)
    substeps = int(round(env.control_timestep / env.model_timestep))
    seconds = 0.0
    for state in states:
        for field, value in state.items():
            getattr(data, field)[:] = value
        start = time.perf_counter()
        for _ in range(substeps):
            mujoco.mj_step(model, data)
        seconds += time.perf_counter() - start
    return seconds


def compare_paths(episodes: int, layout=(1, 1), seed: int = 0, task=None) -> dict:
    """``episodes`` optimal episodes on each path, alternating, after one untimed one, and raw MuJoCo replayed
    from the compiled path's states: ``{"robosuite": [episode, ...], "compiled": [...], "mujoco_s": seconds}``."""
    from tableclean_suite.controllers import make_skill_env

    envs = {name: make_skill_env(*layout, seed=seed, hard_reset=False, fast_control=fast, task=task)
            for name, fast in (("robosuite", False), ("compiled", True))}
    measured = {"robosuite": [], "compiled": [], "mujoco_s": 0.0}
    try:
        run_episode(envs["compiled"], record_states=True)  # untimed: kernels loaded or compiled
        for _ in range(episodes):
            measured["robosuite"].append(run_episode(envs["robosuite"])[0])
            episode, states = run_episode(envs["compiled"], record_states=True)
            measured["compiled"].append(episode)
            measured["mujoco_s"] += replay_mujoco(envs["compiled"], states)
    finally:
        for env in envs.values():
            env.close()
    return measured


def skill_rows(measured: dict) -> list[dict]:
    """Control steps per second of each path of [`compare_paths`][tableclean_suite.bench.speed.compare_paths]'
    ``measured``, relative to robosuite's ``env.step`` and to raw MuJoCo, and seconds per episode."""
    rates = {path: sum(e["steps"] for e in measured[path]) / max(sum(e["env_s"] for e in measured[path]), 1e-12)
             for path in ("robosuite", "compiled")}
    rates["raw MuJoCo"] = sum(e["steps"] for e in measured["compiled"]) / max(measured["mujoco_s"], 1e-12)
    names = {"robosuite": "robosuite env.step", "compiled": "compiled skills", "raw MuJoCo": "raw MuJoCo mj_step"}
    return [{"path": names[path], "control steps/s": f"{rate:.0f}",
             "rate / robosuite env.step": f"{rate / rates['robosuite']:.2f}",
             "rate / raw MuJoCo": f"{rate / rates['raw MuJoCo']:.2f}",
             "s per episode": f"{sum(e['wall_s'] for e in measured[path]) / len(measured[path]):.2f}"
             if path in measured else "-"}
            for path, rate in rates.items()]


def executor_overhead(episodes: list) -> float:
    """The skills' time outside the stepping over their time inside it (a fraction)."""
    inside = sum(e["env_s"] for e in episodes)
    return (sum(e["wall_s"] for e in episodes) - inside) / inside if inside > 0 else float("nan")


def skills_section(args) -> Section:
    """Optimal episodes on robosuite's control path and the compiled one, and raw MuJoCo."""
    measured = compare_paths(args.episodes, tuple(args.layout), args.seed, task=args.task_spec)
    episodes = measured["robosuite"] + measured["compiled"]
    terminal = sum(e["terminal"] for e in episodes)
    note = (f"{args.episodes} optimal episode(s) of task {args.task_spec.name} from layout {tuple(args.layout)} per "
            f"path, alternating; {terminal} of {len(episodes)} reached the terminal state. Raw MuJoCo: "
            "the mj_step calls of each control step from the compiled path's recorded states, nothing else. "
            "Outside the stepping (skill logic, state reads) the compiled skills spend "
            f"{executor_overhead(measured['compiled']):.1%} of the time they spend inside it.")
    return Section([Table("Skills: control steps per second", skill_rows(measured), note)],
                   failed=terminal < len(episodes))


def time_process(argv, cwd: Path, **environment) -> tuple[float, subprocess.CompletedProcess]:
    """Wall seconds and result of ``python ARGV`` in a fresh process in ``cwd``, this package first on its
    path, ``environment`` added to this process's variables."""
    import tableclean_suite

    root = str(Path(tableclean_suite.__file__).resolve().parents[1])
    variables = {**os.environ, **environment,
                 "PYTHONPATH": os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")]))}
    start = time.perf_counter()
    finished = subprocess.run([sys.executable, *argv], cwd=cwd, env=variables, capture_output=True, text=True)
    return time.perf_counter() - start, finished


def cold_start_section(args) -> Section:
    """`COLD_START_PROCESSES` one after the other in a new folder sharing an empty ``NUMBA_CACHE_DIR``: seconds,
    kernels compiled and loaded (``NUMBA_DEBUG_CACHE`` lines), cells resumed, exit code."""
    rows = []
    with tempfile.TemporaryDirectory(prefix="tableclean_speed_") as folder:
        for label, out in COLD_START_PROCESSES:
            seconds, finished = time_process([*COLD_START_COMMAND, "--out", out], Path(folder),
                                             NUMBA_CACHE_DIR=str(Path(folder) / "numba"), NUMBA_DEBUG_CACHE="1")
            log = finished.stdout + finished.stderr
            if finished.returncode != 0:
                last = finished.stderr.strip().splitlines()[-1:] or ["(nothing on stderr)"]
                print(f"{label}: exit code {finished.returncode}: {last[0]}", file=sys.stderr)
            resumed = re.search(r"resumed (\d+) cells", finished.stdout)
            rows.append({"process": label, "seconds": f"{seconds:.2f}",
                         "kernels compiled": len(re.findall(r"\[cache\] data saved", log)),
                         "kernels loaded": len(re.findall(r"\[cache\] data loaded", log)),
                         "cells resumed": resumed.group(1) if resumed else "-", "exit code": finished.returncode})
    command = "python " + " ".join(COLD_START_COMMAND) + " --out DIR"
    return Section([Table(f"Cold start: `{command}` in fresh processes", rows,
                          "One after the other, sharing a numba cache that starts empty; the second process on "
                          "the same DIR reads its result caches, the third writes a new DIR.")],
                   failed=any(row["exit code"] != 0 for row in rows))


SECTION_RUNNERS = {"learners": learners_section, "skills": skills_section, "cold-start": cold_start_section}


def machine() -> dict:
    """What the figures depend on: CPU, cores, OS, Python and package versions, load average, date (UTC)."""
    import datetime
    import platform
    from importlib import metadata

    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            cpu = next((line.split(":", 1)[1].strip() for line in info if line.startswith("model name")), cpu)
    except OSError:
        pass
    stamp = {"CPU": cpu, "cores": os.cpu_count(), "OS": platform.platform(), "Python": platform.python_version()}
    if hasattr(os, "getloadavg"):
        stamp["load average (1, 5, 15 min)"] = ", ".join(f"{load:.1f}" for load in os.getloadavg())
    for name in VERSIONED:
        try:
            stamp[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            stamp[name] = "not installed"
    stamp["date (UTC)"] = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M")
    return stamp


def page(sections: dict, stamp: dict) -> str:
    """The Markdown page of ``sections`` (name -> [`Section`][tableclean_suite.bench.speed.Section]) measured on
    ``stamp``'s machine."""
    lines = ["# Measurements", "",
             "How fast the learners, the skills and a first run are, measured on the machine below by "
             "`tableclean-bench speed --markdown docs/measurements.md`, which rewrites this page. The figures "
             "depend on the machine and its load: compare the ratios, measured side by side in one run, "
             "rather than the seconds.", "",
             "| machine | |", "|---|---|", *[f"| {key} | {value} |" for key, value in stamp.items()]]
    for name, section in sections.items():
        lines += ["", f"## {name}" + (" (a measurement failed)" if section.failed else "")]
        lines += [part for table in section.tables for part in ("", table.markdown())]
    return "\n".join(lines) + "\n"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line."""
    from tableclean_suite.rewards import reward_pattern_names

    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    parser.add_argument("--sections", type=cli.choice_list(SECTIONS, "section"), default=SECTIONS, metavar="NAME,...",
                        help=f"sections to measure, comma separated: {', '.join(SECTIONS)} (default all)")
    parser.add_argument("--markdown", type=cli.output_path(cli.FILE), default=None, metavar="FILE.md",
                        help="also write the measurements to this Markdown page, stamped with the machine")
    parser.add_argument("--repeat", type=cli.positive_int, default=3,
                        help="timed calls per learner, the fastest kept (default 3)")
    group = parser.add_argument_group("learners")
    cli.add_runs_argument(group, 1000, "runs per timed train() call")
    cli.add_iterations_argument(group, 3000, "iterations per run")
    group.add_argument("--reward", choices=reward_pattern_names(), default="r4",
                       help="reward pattern (default r4)")
    group = parser.add_argument_group("skills")
    group.add_argument("--episodes", type=cli.positive_int, default=3,
                       help="optimal episodes per control path (default 3)")
    group.add_argument("--layout", type=cli.positive_int, nargs=2, metavar=("OBJECT_SEGMENT", "ARM_SEGMENT"),
                       default=(1, 1), help="start layout of the skills' episodes, 1-based segments (every object "
                                            "on OBJECT_SEGMENT; default: 1 1, the paper's layout)")
    cli.add_task_argument(group, help="task spec of the skills' episodes: a registered name or a .json path "
                                      "(default paper)")
    cli.add_seed_argument(parser, "the skills' scenes")
    return parser


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    if "skills" in args.sections:  # --task and --layout, before any measurement
        from tableclean_suite.bench.fidelity import physical_model

        args.task_spec = physical_model(parser, args.task).spec
        if any(not 1 <= k <= args.task_spec.segments for k in args.layout):
            parser.error(f"--layout: segments must be in 1..{args.task_spec.segments} for task "
                         f"{args.task_spec.name!r}, got {list(args.layout)}")
    sections = {}
    for name in (name for name in SECTIONS if name in args.sections):  # in report order
        print(f"== {name} ==", flush=True)
        sections[name] = SECTION_RUNNERS[name](args)
        for table in sections[name].tables:
            print(table.text() + "\n", flush=True)
    if args.markdown is not None:
        from tableclean_suite.bench.outputs import atomic_write_text

        Path(args.markdown).parent.mkdir(parents=True, exist_ok=True)
        atomic_write_text(Path(args.markdown), page(sections, machine()))
        print(f"wrote {args.markdown}")
    return 1 if any(section.failed for section in sections.values()) else 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("speed", "python -m tableclean_suite.bench.speed"))
