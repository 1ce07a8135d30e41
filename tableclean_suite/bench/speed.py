"""``tableclean-bench speed``: every speed goal of the suite, measured in sections, each goal named and checked.

    tableclean-bench speed                                   # every section (several minutes)
    tableclean-bench speed --sections learners,specs         # some of them
    tableclean-bench speed --sections environment --steps 200 --rounds 4

Sections (``--sections``, comma separated, default all), in this order:

``learners``
    the compiled learners against a plain per-step Python loop (goal: >= :data:`PLAIN_LOOP_GOAL`
    times faster), every registered learner against Q-learning (:mod:`.learner_speed`), every
    exploration, and the default run after a warm-up (goal: <= :data:`DEFAULT_RUN_GOAL_S` s);
``specs``
    the compiled learner's per-update rate on the scaling study's largest spec against the
    paper's (:mod:`.spec_speed`);
``cold-start``
    the README's command in three fresh processes sharing one numba cache (:mod:`.spec_speed`);
``environment``
    ``env.step`` rate of TableClean against robosuite's Lift (:mod:`.env_speed`);
``skills``
    control steps and wall time of the skills in physics, and the fast control path against
    robosuite's (:mod:`.skill_speed`).

``--old-tree DIR`` (a checkout of an older tree) adds two goals measured as ratios in the same
run (:mod:`.tree_ratio`): the learners section times the default run's whole process, the
cold-start section the first process, alternately here and in ``DIR``.

The report ends with one line per goal: what was measured and whether the goal is met.  Exit
code 0 whatever the goals say; 1 when a measurement itself failed (a cold-start process that
exited non-zero, a skill episode that did not reach the terminal state); 2 on bad flags.
The old commands (``python -m benchmarks.speed``, ``learner_speed``, ``spec_speed``,
``env_speed``, ``skill_speed``) are aliases selecting sections (:data:`ALIASES`) with their old flags.

Learners section, in detail.  Both sides run in this process on the same task.  Two baselines:
- ``plain loop``: a lean hand-written Python loop of Algorithm 1 over precomputed
  transition lists with ``random.random()`` (the fastest plain Python we could write),
- ``reference engine``: ``train(engine="reference")``, the library's own per-step loop
  (which also serves the physics backend and draws the same random numbers).
The compiled learners are timed after a warm-up call (numba compilation excluded).
It also times the whole default ``tableclean-bench run --fresh`` (all cells trained,
bootstraps, tables, CSVs, figures drawn: no result cache) in this process after a warm-up run,
:data:`DEFAULT_RUN_REPEATS` times: the median run's CPU seconds and wall seconds; the per-update
rate on the scaling study's largest spec against
the paper's (:mod:`.spec_speed`); and the cold start, measured in one go
(:func:`.spec_speed.time_cold_starts`): the README's command in three fresh processes sharing a
numba cache that starts empty — the first process (empty numba and result caches), a second
one on the same output directory (warm caches: the README's second run, goal <= 3 s) and a
second one on a new output directory (result caches off, numba's cache only).
"""

from __future__ import annotations

import argparse
import random
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

from tableclean_suite.bench import cli
from tableclean_suite.bench.cli import positive_int
from tableclean_suite.bench.goal_text import against_goal, seconds_against_goal
from tableclean_suite.bench.tree_ratio import FIRST_PROCESS_GOAL_S  # noqa: F401  (the cold start's goal, s)
from tableclean_suite.learners import train
from tableclean_suite.rewards import get_reward_pattern
from tableclean_suite.task import Outcome, TaskModel

LEARNERS = ("q_learning", "sarsa")
#: Goal: the compiled learners at least this many times the plain loop's updates per second.
PLAIN_LOOP_GOAL = 100.0
#: Goal: the default run, after a warm-up in the same process, within this many wall seconds.
DEFAULT_RUN_GOAL_S = 4.0
#: Timed default runs after the warm-up; the median's wall time is checked against the goal.
DEFAULT_RUN_REPEATS = 3
#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench speed"
#: The sections, in the order they run and report.
SECTIONS = ("learners", "specs", "cold-start", "environment", "skills")


def plain_loop(learner: str, runs: int, iterations: int, alpha=0.3, gamma=0.3, epsilon=0.1, max_itr=500, seed=0):
    """Algorithm 1 as a straightforward Python loop (r2 rewards, no looping penalty). Returns updates done."""
    rng = random.Random(seed)
    model = TaskModel()
    n_actions = model.n_actions
    next_state, outcome = (a.tolist() for a in model.transition_arrays())
    values = get_reward_pattern("r2").outcome_values().tolist()
    start = model.start_state.index
    terminal_outcome = int(Outcome.TERMINAL)
    sarsa = learner == "sarsa"

    def choose(row):
        if rng.random() < epsilon:
            return rng.randrange(n_actions)
        return row.index(max(row))

    for _ in range(runs):
        q = [[0.0] * n_actions for _ in range(len(next_state))]
        state, length, action = start, 0, None
        for _ in range(iterations):
            if action is None:
                action = choose(q[state])
            nxt, out = next_state[state][action], outcome[state][action]
            reward = values[out]
            length += 1
            terminal = out == terminal_outcome
            next_action = None if terminal else choose(q[nxt])
            if terminal:
                target = reward
            elif sarsa:
                target = reward + gamma * q[nxt][next_action]
            else:
                target = reward + gamma * max(q[nxt])
            q[state][action] += alpha * (target - q[state][action])
            if terminal or length >= max_itr:
                state, length, action = start, 0, None
            else:
                state, action = nxt, (next_action if sarsa else None)
    return runs * iterations


def _rate(function) -> float:
    start = time.perf_counter()
    updates = function()
    return updates / (time.perf_counter() - start)


def measure(runs: int, iterations: int, baseline_runs: int) -> list[dict]:
    """Updates per second of each learner and of both baselines, and the ratios."""
    rows = []
    for learner in LEARNERS:
        train(learner, "r2", runs=2, iterations=10)  # warm-up: compile
        compiled = _rate(lambda: train(learner, "r2", runs=runs, iterations=iterations) and runs * iterations)
        plain = _rate(lambda: plain_loop(learner, baseline_runs, iterations))
        reference = _rate(
            lambda: train(learner, "r2", runs=baseline_runs, iterations=iterations, engine="reference")
            and baseline_runs * iterations
        )
        rows.append(
            {
                "learner": learner,
                "compiled_updates_per_s": compiled,
                "plain_loop_updates_per_s": plain,
                "reference_updates_per_s": reference,
                "ratio_vs_plain_loop": compiled / plain,
                "ratio_vs_reference": compiled / reference,
            }
        )
    return rows


def time_default_run(repeats: int = DEFAULT_RUN_REPEATS) -> dict:
    """CPU and wall seconds of the default ``tableclean-bench run``, after a warm-up run in this process.

    Returns:
        ``{"wall_s", "cpu_s"}`` of the run with the median wall time of ``repeats`` (>= 1) timed runs,
        and ``"walls"``, every run's wall seconds in order (the cores are shared: their spread says how much).
        CPU seconds are this process's (the figures' drawing processes are not counted).
    """
    import contextlib
    import io
    import tempfile

    from tableclean_suite.bench import run

    timings = []
    with tempfile.TemporaryDirectory() as out:
        argv = ["--out", out, "--fresh", "--no-progress"]
        def run_once() -> None:
            code = run.main(argv)
            if code == run.EXIT_INTERRUPTED:  # Ctrl-C, which run.main turned into its exit code
                raise KeyboardInterrupt
            if code:
                raise RuntimeError(f"the default run exited with {code}; no timing taken")

        with contextlib.redirect_stdout(io.StringIO()):
            run_once()  # warm-up: numba compilation, matplotlib font cache
            for _ in range(max(1, int(repeats))):
                cpu, wall = time.process_time(), time.perf_counter()
                run_once()
                timings.append({"cpu_s": time.process_time() - cpu, "wall_s": time.perf_counter() - wall})
    median = sorted(timings, key=lambda timing: timing["wall_s"])[(len(timings) - 1) // 2]
    return {**median, "walls": [timing["wall_s"] for timing in timings]}



# ---------------------------------------------------------------------------------------------
# the report: sections and goals
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Goal:
    """One speed goal and its measurement.

    Attributes:
        section: the section (of :data:`SECTIONS`) that measured it.
        goal: what is asked, e.g. ``"TableClean / Lift env.step rate >= 0.9"``.
        measured: what was measured, e.g. ``"0.93"``.
        met: whether the measurement meets the goal.
    """

    section: str
    goal: str
    measured: str
    met: bool

    def line(self) -> str:
        """``section: goal: measured -> met`` for the report."""
        return f"  {self.section:<12} {self.goal}: {self.measured} -> {'met' if self.met else 'NOT met'}"


@dataclass
class SectionResult:
    """What a section printed, its goals, and whether its measurement itself succeeded."""

    goals: list[Goal] = field(default_factory=list)
    failed: bool = False


def _table(rows: list[dict], float_format: str) -> str:
    import pandas as pd

    with pd.option_context("display.float_format", float_format.format, "display.width", 200):
        return pd.DataFrame(rows).to_string(index=False)


def learners_section(args) -> SectionResult:
    """The compiled learners against the plain loop, every learner and exploration, the default run."""
    from tableclean_suite.bench import learner_speed, tree_ratio

    result = SectionResult()
    rows = measure(args.runs, args.iterations, args.baseline_runs)
    print(_table(rows, "{:,.1f}"))
    worst = min(row["ratio_vs_plain_loop"] for row in rows)
    result.goals.append(Goal("learners", f"compiled learners >= {PLAIN_LOOP_GOAL:g}x the plain Python loop",
                             f"{worst:.0f}x (worst learner)", worst >= PLAIN_LOOP_GOAL))
    print(f"\nevery learner: paper spec, reward {args.reward}, {args.runs} runs x {args.iterations} iterations, "
          f"best of {args.repeat} (wall clock, all cores)")
    learner_rows = learner_speed.learner_rows(args.reward, args.runs, args.iterations, args.repeat)
    print(_table(learner_rows, "{:,.2f}"))
    name, ratio = learner_speed.slowest(learner_rows)
    result.goals.append(Goal("learners", f"no learner but Dyna-Q more than {learner_speed.SLOWDOWN_GOAL:g}x slower "
                             "per update than Q-learning", f"slowest {name}, {ratio:.2f}x",
                             ratio <= learner_speed.SLOWDOWN_GOAL))
    if not args.skip_explorations:
        print()
        print(_table(learner_speed.exploration_rows(args.reward, args.runs, args.iterations, args.repeat),
                     "{:,.2f}"))
    if args.old_tree is not None:
        against = _against_old_tree(args, "default run", False, tree_ratio.DEFAULT_RUN_RATIO_GOAL, "a third")
        result.goals += against.goals
        result.failed = result.failed or against.failed
    if not args.skip_default_run:
        timing = time_default_run()
        print(f"\ndefault `tableclean-bench run --fresh` after warm-up, median of {len(timing['walls'])} runs: "
              f"{timing['cpu_s']:.2f} s CPU, {timing['wall_s']:.2f} s wall "
              f"(every run: {', '.join(f'{wall:.2f}' for wall in timing['walls'])} s)")
        result.goals.append(Goal("learners", f"default run after warm-up <= {DEFAULT_RUN_GOAL_S:g} s wall",
                                 f"{seconds_against_goal(timing['wall_s'], DEFAULT_RUN_GOAL_S)}; "
                                 f"{timing['cpu_s']:.2f} s CPU", timing["wall_s"] <= DEFAULT_RUN_GOAL_S))
    return result


def specs_section(args) -> SectionResult:
    """The compiled learner's rate on the largest scaling spec against the paper's."""
    from tableclean_suite.bench import spec_speed
    from tableclean_suite.task import get_task_spec

    paper, largest = spec_speed.measure_rates([get_task_spec("paper"), spec_speed.largest_study_spec()],
                                              args.spec_runs, args.spec_iterations, args.spec_repeats)
    print("\n".join(spec_speed.summary_lines(paper, largest, [])))
    ratio = spec_speed.rate_ratio(largest, paper)
    return SectionResult([Goal("specs", f"largest spec's rate within {spec_speed.TARGET_SLOWDOWN:g}x of the paper's",
                               f"ratio {ratio:.2f}", spec_speed.within_target(ratio))])


def _against_old_tree(args, label: str, cold: bool, goal: float, goal_text: str) -> SectionResult:
    """This tree's whole run process against ``--old-tree``'s, in alternating pairs (:mod:`.tree_ratio`):
    its goal, or a failed measurement (a run exited non-zero in either tree)."""
    from tableclean_suite.bench import tree_ratio

    section = "cold-start" if cold else "learners"
    try:
        times = tree_ratio.paired_times(label, tree_ratio.this_tree(), args.old_tree, args.old_tree_pairs, cold)
    except tree_ratio.TreeRunError as error:
        print(f"  {label} against --old-tree: {error}")
        return SectionResult([Goal(section, f"{label} / --old-tree's (whole processes) <= {goal:.3f}",
                                   "not measured", False)], failed=True)
    print(f"{label}, whole processes alternating with --old-tree {args.old_tree}:")
    print(times.line())
    measured = against_goal(f"{times.ratio:.3f}", times.ratio, goal, f"{goal:.3f} ({goal_text})", True,
                            f"{abs(times.ratio - goal):.3f}")
    return SectionResult([Goal(section, f"{label} / --old-tree's (whole processes) <= {goal:.3f}", measured,
                               times.ratio <= goal)])


def cold_start_section(args) -> SectionResult:
    """The README's command in three fresh processes sharing one numba cache (and, with
    ``--old-tree``, the first process against the older tree's)."""
    from tableclean_suite.bench import spec_speed, tree_ratio

    against = SectionResult()
    if getattr(args, "old_tree", None) is not None:
        against = _against_old_tree(args, "first process", True, tree_ratio.FIRST_PROCESS_RATIO_GOAL,
                                    f"{tree_ratio.FIRST_PROCESS_GOAL_S:g} of {tree_ratio.ISSUE_FIRST_PROCESS_S:g} s")
    cold = spec_speed.time_cold_starts()
    print("\n".join(spec_speed.cold_start_lines(cold)))
    warm = spec_speed.warm_process(cold)
    result = SectionResult(list(against.goals),
                           failed=against.failed or any(process.returncode != 0 for process in cold))
    if cold:
        result.goals.append(Goal("cold-start", f"first process (empty kernel cache) <= {FIRST_PROCESS_GOAL_S:g} s",
                                 f"{seconds_against_goal(cold[0].seconds, FIRST_PROCESS_GOAL_S)}; "
                                 f"{cold[0].compiled} kernels compiled",
                                 cold[0].seconds <= FIRST_PROCESS_GOAL_S and cold[0].returncode == 0))
    if warm is not None:
        result.goals.append(Goal("cold-start", f"second process with warm caches <= "
                                 f"{spec_speed.TARGET_SECOND_PROCESS:g} s",
                                 seconds_against_goal(warm.seconds, spec_speed.TARGET_SECOND_PROCESS),
                                 spec_speed.warm_within_target(warm)))
    return result


def environment_section(args) -> SectionResult:
    """``env.step`` rate of TableClean against robosuite's Lift."""
    from tableclean_suite.bench import env_speed

    rates = env_speed.measure(args.steps, args.rounds, args.control_freq, args.seed)
    print("\n".join(env_speed.report_lines(rates)))
    ratio = env_speed.rate_ratio(rates)
    return SectionResult([Goal("environment", f"TableClean / Lift env.step rate >= {env_speed.RATIO_GOAL:g}",
                               f"{ratio:.3f}", ratio >= env_speed.RATIO_GOAL)])


def skills_section(args) -> SectionResult:
    """Optimal episodes of the skills, on robosuite's control path and the fast one."""
    from tableclean_suite.bench import skill_speed

    spec = args.task_spec
    comparison = skill_speed.compare_paths(args.episodes, tuple(args.layout), args.seed, task=spec)
    print(f"task {spec.name}, layout {tuple(args.layout)}")
    print(skill_speed.format_report(comparison["fast"]))
    print()
    print(skill_speed.format_comparison(comparison))
    numbers = skill_speed.goal_numbers(comparison)
    episodes = comparison["fast"]["episodes"] + comparison["robosuite"]["episodes"]
    return SectionResult([
        Goal("skills", f"optimal episode <= {skill_speed.EPISODE_GOAL_S:g} s (mean, fast path)",
             seconds_against_goal(numbers["episode_s"], skill_speed.EPISODE_GOAL_S),
             numbers["episode_s"] <= skill_speed.EPISODE_GOAL_S),
        Goal("skills", f"executor overhead over env.step <= {skill_speed.OVERHEAD_GOAL:.0%}",
             skill_speed.overhead_against_goal(numbers["overhead"]), numbers["overhead"] <= skill_speed.OVERHEAD_GOAL),
        Goal("skills", f"fast path >= {skill_speed.FAST_SPEEDUP_GOAL:g}x robosuite's control steps/s",
             skill_speed.speedup_against_goal(numbers["speedup"]), numbers["speedup"] >= skill_speed.FAST_SPEEDUP_GOAL),
        Goal("skills", f"fast path >= {skill_speed.RAW_MUJOCO_GOAL:g} of raw MuJoCo's control steps/s",
             skill_speed.raw_ratio_against_goal(numbers["raw_ratio"]),
             numbers["raw_ratio"] >= skill_speed.RAW_MUJOCO_GOAL),
    ], failed=not all(episode["terminal"] for episode in episodes))


#: Each section's function, by name.
SECTION_RUNNERS = {"learners": learners_section, "specs": specs_section, "cold-start": cold_start_section,
                   "environment": environment_section, "skills": skills_section}


# ---------------------------------------------------------------------------------------------
# the command line
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Alias:
    """An old speed command: the sections it selects and its flags' old spellings.

    Attributes:
        sections: sections it runs.
        flags: ``{option dest: old flag}`` for options it spelled differently.
    """

    sections: tuple[str, ...]
    flags: dict = field(default_factory=dict)


#: The old commands, as sections of this one (``python -m benchmarks.NAME`` keeps working).
ALIASES = {
    "speed": Alias(("learners", "specs", "cold-start")),
    "learner_speed": Alias(("learners",)),
    "spec_speed": Alias(("specs", "cold-start"), {"spec_runs": "--runs", "spec_iterations": "--iterations",
                                                   "spec_repeats": "--repeats"}),
    "env_speed": Alias(("environment",)),
    "skill_speed": Alias(("skills",)),
}


def section_list(text: str) -> tuple[str, ...]:
    """``"specs,learners"`` -> ``("learners", "specs")``: known section names, in report order."""
    chosen = set(cli.name_list(text))
    unknown = sorted(chosen - set(SECTIONS))
    if unknown:
        raise argparse.ArgumentTypeError(f"unknown section {', '.join(map(repr, unknown))}; allowed: "
                                         f"{', '.join(SECTIONS)} (comma separated)")
    return tuple(name for name in SECTIONS if name in chosen)


def reward_name(text: str) -> str:
    """A registered reward pattern's name."""
    from tableclean_suite.rewards import reward_pattern_names

    if text not in reward_pattern_names():
        raise argparse.ArgumentTypeError(f"unknown reward pattern {text!r}; allowed: {', '.join(reward_pattern_names())}")
    return text


def build_parser(prog: str = PROG, alias: str | None = None) -> argparse.ArgumentParser:
    """The command line; ``alias`` (a key of :data:`ALIASES`) builds an old command's: only its sections'
    options, spelled as it spelled them, and no ``--sections``."""
    from tableclean_suite.bench import env_speed, spec_speed

    chosen = ALIASES[alias] if alias is not None else None
    sections = chosen.sections if chosen is not None else SECTIONS
    flags = chosen.flags if chosen is not None else {}
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    if chosen is None:
        parser.add_argument("--sections", type=section_list, default=SECTIONS, metavar="NAME,...",
                            help=f"sections to measure, comma separated: {', '.join(SECTIONS)} (default all)")

    def option(group, dest: str, flag: str, **options):
        group.add_argument(flags.get(dest, flag), dest=dest, **options)

    if "learners" in sections:
        group = parser.add_argument_group("learners")
        option(group, "runs", "--runs", type=positive_int, default=1000, help="runs per timed call (default 1000)")
        option(group, "iterations", "--iterations", type=positive_int, default=3000,
               help="iterations per run (default 3000)")
        option(group, "baseline_runs", "--baseline-runs", type=positive_int, default=20,
               help="runs of the plain baselines (default 20)")
        option(group, "repeat", "--repeat", type=positive_int, default=3,
               help="timed calls per learner, the fastest kept (default 3)")
        option(group, "reward", "--reward", type=reward_name, default="r4",
               help="reward pattern of the every-learner table (default r4)")
        option(group, "skip_explorations", "--skip-explorations", action="store_true",
               help="do not time the explorations")
        option(group, "skip_default_run", "--skip-default-run", action="store_true",
               help="do not time the default run")
    if "specs" in sections:
        group = parser.add_argument_group("specs")
        option(group, "spec_runs", "--spec-runs", type=positive_int, default=spec_speed.DEFAULT_RUNS,
               help=f"runs per timed call (default {spec_speed.DEFAULT_RUNS})")
        option(group, "spec_iterations", "--spec-iterations", type=positive_int, default=spec_speed.DEFAULT_ITERATIONS,
               help=f"iterations per run (default {spec_speed.DEFAULT_ITERATIONS})")
        option(group, "spec_repeats", "--spec-repeats", type=positive_int, default=spec_speed.DEFAULT_REPEATS,
               help=f"timed calls per spec, the fastest kept (default {spec_speed.DEFAULT_REPEATS})")
        option(group, "skip_specs", "--skip-specs", action="store_true",
               help="skip the specs and cold-start sections (as the old speed command)")
    if "cold-start" in sections:
        group = parser.add_argument_group("cold start")
        option(group, "no_cold_start", "--no-cold-start", action="store_true",
               help="skip the three fresh-process timings of the run command")
    if "environment" in sections:
        group = parser.add_argument_group("environment")
        option(group, "steps", "--steps", type=positive_int, default=env_speed.DEFAULT_STEPS,
               help=f"timed env.step calls per environment, >= --rounds (default {env_speed.DEFAULT_STEPS})")
        option(group, "rounds", "--rounds", type=positive_int, default=env_speed.DEFAULT_ROUNDS,
               help=f"alternating timing blocks (default {env_speed.DEFAULT_ROUNDS})")
        option(group, "control_freq", "--control-freq", type=positive_int, default=env_speed.DEFAULT_CONTROL_FREQ,
               help=f"control frequency of every env, Hz (default {env_speed.DEFAULT_CONTROL_FREQ})")
    if "skills" in sections:
        group = parser.add_argument_group("skills")
        option(group, "episodes", "--episodes", type=positive_int, default=3,
               help="optimal episodes per control path (default 3)")
        option(group, "layout", "--layout", type=positive_int, nargs=2, metavar=("OBJECT_SEGMENT", "ARM_SEGMENT"),
               default=(1, 1), help="start layout, 1-based segments (every object on OBJECT_SEGMENT; default: 1 1, "
                                    "the paper's layout)")
        cli.add_task_argument(group, help="task spec of the skills section: a registered name or a .json path "
                                          "(default paper)")
    if "environment" in sections or "skills" in sections:
        cli.add_seed_argument(parser, "the environments and their random actions")
    if "learners" in sections or "cold-start" in sections:
        from tableclean_suite.bench import tree_ratio

        group = parser.add_argument_group("against an older tree (learners: the default run; cold-start: the "
                                          "first process)")
        group.add_argument("--old-tree", type=Path, default=None, metavar="DIR",
                           help="a checkout of an older tree (e.g. `git worktree add DIR f690eb5`): time the run "
                                "command's whole process alternately here and there and check the ratio "
                                f"(default run <= 1/3, first process <= {tree_ratio.FIRST_PROCESS_RATIO_GOAL:.3f})")
        group.add_argument("--old-tree-pairs", type=positive_int, default=tree_ratio.DEFAULT_PAIRS, metavar="N",
                           help=f"pairs of processes per ratio (default {tree_ratio.DEFAULT_PAIRS})")
    return parser


def _selected(args, alias: str | None) -> tuple[str, ...]:
    sections = list(ALIASES[alias].sections if alias is not None else args.sections)
    if getattr(args, "skip_specs", False):
        sections = [name for name in sections if name not in ("specs", "cold-start")]
    if getattr(args, "no_cold_start", False):
        sections = [name for name in sections if name != "cold-start"]
    return tuple(sections)


def _check(parser, args, sections) -> None:
    """Checks that need more than one flag, or a registry; exits 2 naming the flag."""
    if getattr(args, "old_tree", None) is not None:
        from tableclean_suite.bench import tree_ratio

        if "learners" not in sections and "cold-start" not in sections:
            parser.error(f"--old-tree times the learners and cold-start sections, and neither is selected "
                         f"(sections: {', '.join(sections)})")
        problem = tree_ratio.tree_problem(args.old_tree)
        if problem:
            parser.error(f"--old-tree: {problem}")
        problem = tree_ratio.tree_problem(tree_ratio.this_tree())
        if problem:
            parser.error(f"--old-tree needs this package run from a source checkout; {problem}")
    if "environment" in sections and args.steps < args.rounds:
        parser.error(f"--steps {args.steps} is below --rounds {args.rounds}: every round times at least one step")
    if "skills" in sections:
        from tableclean_suite.task import get_task_spec

        try:
            args.task_spec = get_task_spec(args.task)
        except (ValueError, OSError) as error:
            parser.error(f"--task: {error}")
        segments = args.task_spec.segments
        if any(not 1 <= k <= segments for k in args.layout):
            parser.error(f"--layout: segments must be in 1..{segments} for task {args.task_spec.name!r}, "
                         f"got {list(args.layout)}")
        from tableclean_suite.physics_backend import check_physical_task  # imports MuJoCo: after the cheap checks

        try:
            check_physical_task(TaskModel(spec=args.task_spec))
        except ValueError as error:
            parser.error(f"--task: {error}")


def main(argv=None, prog: str | None = None, alias: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code (see the module doc).

    ``alias``: run as one of the old commands (:data:`ALIASES`).
    """
    if alias is not None and alias not in ALIASES:
        raise ValueError(f"unknown speed alias {alias!r}; allowed: {', '.join(ALIASES)}")
    parser, args = cli.parse_command(lambda name: build_parser(name, alias), argv,
                                     prog or (f"python -m benchmarks.{alias}" if alias else PROG))
    sections = _selected(args, alias)
    if not sections:
        parser.error("no section left to measure")
    _check(parser, args, sections)
    goals, failed = [], False
    for name in sections:
        print(f"== {name} ==")
        result = SECTION_RUNNERS[name](args)
        goals += result.goals
        failed = failed or result.failed
        print()
    print("goals:")
    for goal in goals:
        print(goal.line())
    print(f"{sum(goal.met for goal in goals)} of {len(goals)} goals met")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(prog="python -m tableclean_suite.bench.speed"))
