"""Collect skill demonstrations in robomimic's hdf5 layout.

    tableclean-bench demos --task three_segments --episodes 20 --policy learned --workers 2

Each demo starts from a random all-unclean layout of the spec (placement noise seeded); the
SkillController then executes the model's shortest plan (``optimal``) or the majority greedy policy
of ``--runs`` Q-learning r4 runs on the symbolic model (``learned``), and every control step is
recorded (layout: the Datasets page).  Failed executions are discarded and redrawn, at most
`MAX_ATTEMPTS_PER_EPISODE` draws per demo.

Attempt ``k`` draws its start and placement seed from ``(--seed, k)`` alone and is one executor task
([`DemoAttempt`][tableclean_suite.bench.collect_demos.DemoAttempt]), so ``--workers N`` or ``--executor ray``
write the same file as one process.  Exit codes: 0 all demos written, 1 fewer demos than requested (those
found are written) or an attempt that raised (nothing written), 2 bad flags.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tableclean_suite.bench import cli
from tableclean_suite.bench.rollout import train_policy
from tableclean_suite.demos import VALID_FRACTION
from tableclean_suite.executors.blas import single_blas_thread
from tableclean_suite.robosuite_adapter import apply_verbosity
from tableclean_suite.task import TaskModel, TaskSpec

POLICIES = ("optimal", "learned")
OUT_SUFFIXES = (".hdf5", ".h5")
#: Start-layout draws per requested demo before giving up (failed executions are redrawn).
MAX_ATTEMPTS_PER_EPISODE = 3
#: The learned policy's learner and reward pattern (the paper's best configuration).
LEARNER, REWARD = "q_learning", "r4"
DEFAULT_EPISODES = 10
DEFAULT_ITERATIONS = 20000  # the paper, three_segments and two_objects from every start (5 runs, seed 0)
DEFAULT_RUNS = 5
DEFAULT_MAX_ACTIONS = 50
#: Bound of the per-episode placement seeds drawn from ``--seed`` (exclusive).
PLACEMENT_SEED_BOUND = 2**31
#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench demos"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: the shared options of [`cli`][tableclean_suite.bench.cli] and the collection's own."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    cli.add_task_argument(parser)
    parser.add_argument("--episodes", type=cli.positive_int, default=DEFAULT_EPISODES,
                        help=f"successful demos to record (default {DEFAULT_EPISODES})")
    cli.add_robots_argument(parser)
    parser.add_argument("--policy", default="optimal", choices=POLICIES,
                        help="optimal: the shortest plan; learned: greedy Q-learning r4 policy (default optimal)")
    cli.add_seed_argument(parser, "the start layouts, the placement noise and the training")
    cli.add_out_argument(parser, cli.FILE, None, "output .hdf5 (results/demos_<task>_<policy>.hdf5 when not given)",
                         suffixes=OUT_SUFFIXES)
    cli.add_iterations_argument(parser, DEFAULT_ITERATIONS, "learned: training iterations per run")
    cli.add_runs_argument(parser, DEFAULT_RUNS, "learned: training runs voting on the policy")
    parser.add_argument("--max-actions", type=cli.positive_int, default=DEFAULT_MAX_ACTIONS,
                        help=f"learned: actions per episode before it counts as failed (default {DEFAULT_MAX_ACTIONS})")
    parser.add_argument("--valid-fraction", type=cli.number_type(float, lambda v: 0 <= v < 1, "a fraction in [0, 1)"),
                        default=VALID_FRACTION,
                        help=f"fraction of the demos in mask/valid, in [0, 1) (default {VALID_FRACTION})")
    cli.add_executor_arguments(parser, "episodes")  # --workers, --executor, --ray-address (as fidelity)
    return parser


def reaches_goal(model, start, policy: np.ndarray, max_actions: int) -> bool:
    """Whether ``policy`` (``(S,)`` action indices) leads from ``start`` to a terminal state of the task model
    within ``max_actions``."""
    state = start
    for _ in range(max_actions):
        if state.is_terminal:
            return True
        state = model.step(state, int(policy[state.index]))[0]
    return state.is_terminal


def attempt_draws(model, seed: int, attempt: int):
    """``(start state, placement seed)`` of attempt ``attempt`` (0-based), drawn from ``(seed, attempt)`` alone."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), int(attempt)]))
    start = model.sample_start(float(rng.random()))
    return start, int(rng.integers(PLACEMENT_SEED_BOUND))


@dataclass(frozen=True)
class DemoAttempt:
    """One attempt as an executor task of plain values: the spec as JSON, ``--task`` as given (stored in
    ``env_args``), the robot, the policy's name and its action per state code, the actions before an
    episode counts as failed, ``--seed`` and the 0-based attempt number."""

    spec: str
    task: str
    robot: str
    policy_name: str
    policy: tuple
    max_actions: int
    seed: int
    attempt: int

    @property
    def label(self) -> str:
        return f"demo attempt {self.attempt}"


@dataclass
class AttemptResult:
    """What [`record_attempt`][tableclean_suite.bench.collect_demos.record_attempt] returns: the demo (None
    when discarded) and what to log."""

    attempt: int
    start_name: str
    demo: object | None
    problem: str | None
    env_args: dict = field(default_factory=dict)
    seconds: float = 0.0


def _scene(task: DemoAttempt, spec: TaskSpec, model: TaskModel):
    """A new scene of ``task`` (``spec`` as given, ``model`` its uniform start): ``(env, staging controller,
    env_args)``."""
    import multiprocessing

    from tableclean_suite.controllers import SkillController, make_skill_env, skill_controller_config
    from tableclean_suite.demos import env_args_of

    if multiprocessing.parent_process() is not None:  # a worker process: robosuite's start-up lines are noise
        apply_verbosity(False)
    try:
        env = make_skill_env(task=spec, robots=task.robot)
    except NotImplementedError:  # the fast path does not reproduce this robot's controller
        env = make_skill_env(task=spec, robots=task.robot, fast_control=False)
    return env, SkillController(env, model), env_args_of(env, task.task, skill_controller_config(task.robot, None))


@single_blas_thread()  # its thread count changes the trajectories' last bits
def record_attempt(task: DemoAttempt) -> AttemptResult:
    """Run one [`DemoAttempt`][tableclean_suite.bench.collect_demos.DemoAttempt] in this process: draw its
    start, build its scene, stage it, execute and record."""
    from tableclean_suite.demos import EpisodeRecorder, recording_controller
    from tableclean_suite.physics_backend import StagingError, stage

    spec = TaskSpec.from_dict(json.loads(task.spec))
    model = TaskModel(spec=spec, start="uniform_unclean")
    policy = np.asarray(task.policy, dtype=np.int64)
    start, placement_seed = attempt_draws(model, task.seed, task.attempt)
    if not reaches_goal(model, start, policy, task.max_actions):
        return AttemptResult(task.attempt, start.name, None,
                             f"the {task.policy_name} policy does not reach the goal from {start.name}")
    env, staging, env_args = _scene(task, spec, model)
    try:
        stage(env, staging, start, seed=placement_seed)
    except StagingError as error:
        env.close()
        return AttemptResult(task.attempt, start.name, None, str(error), env_args)
    started = time.perf_counter()
    recorder = EpisodeRecorder(env)
    controller = recording_controller(env, model, recorder)
    state, problem = start, None
    try:
        for _ in range(task.max_actions):
            action = int(policy[state.index])
            recorder.begin(model.action_name(action), action)
            result = controller.execute(action)
            if result.state_after is None:
                problem = f"fault after {model.action_name(action)}: {result.reason}"
                break
            if task.policy_name == "optimal" and not result.success:  # the shortest plan, as planned or not at all
                problem = f"{model.action_name(action)} failed: {result.reason}"
                break
            state = result.state_after
            if state.is_terminal:
                break
        demo = recorder.finish(attrs={"start_state": start.index, "start_state_name": start.name,
                                      "placement_seed": placement_seed, "policy": task.policy_name})
    finally:
        env.close()
    if problem is None and not demo.attrs["success"]:
        problem = f"ended in {state.name} without success"
    return AttemptResult(task.attempt, start.name, None if problem else demo, problem, env_args,
                         time.perf_counter() - started)


def collect(task: str, episodes: int, robot: str = "Panda", policy_name: str = "optimal", seed: int = 0,
            iterations: int = DEFAULT_ITERATIONS, runs: int = DEFAULT_RUNS, max_actions: int = DEFAULT_MAX_ACTIONS,
            log=print, executor=None) -> tuple[list, dict, dict]:
    """Record up to ``episodes`` successful demos; returns ``(demos, env_args, data_attrs)``.

    ``task``: a registered spec name or a ``.json`` path; ``policy_name``: one of `POLICIES` (the learned
    policy acts closed-loop on the state read back).  Attempts run on ``executor`` (default: this process) in
    waves; the demos are the first successful ones in attempt order.

    Raises:
        tableclean_suite.executors.TaskFailedError: an attempt raised (naming it).
    """
    from tableclean_suite.executors import LocalExecutor
    from tableclean_suite.task import get_task_spec

    spec = get_task_spec(task)
    model = TaskModel(spec=spec, start="uniform_unclean")
    if policy_name == "optimal":  # following it is the shortest plan, at most one action per state
        policy, max_actions = model.optimal_policy(), spec.n_states
    else:
        started = time.perf_counter()
        policy = train_policy(LEARNER, REWARD, model, runs, iterations, seed)
        solved = sum(reaches_goal(model, s, policy, max_actions) for s in model.start_states())
        log(f"trained {LEARNER} {REWARD} on {spec.name}: {runs} run(s) x {iterations} iterations "
            f"in {time.perf_counter() - started:.1f} s; its greedy policy reaches the goal from {solved} of "
            f"{len(model.start_states())} start layouts in the model")
        if not solved:
            log("no start layout to record from; train longer (--iterations, --runs)")
            return [], {}, {}
    executor = executor if executor is not None else LocalExecutor(workers=1)
    spec_json = json.dumps(spec.to_dict(), sort_keys=True)
    policy_values = tuple(int(a) for a in policy)
    demos, discarded, env_args = [], 0, {}
    limit = episodes * MAX_ATTEMPTS_PER_EPISODE
    next_attempt = 0
    while len(demos) < episodes and next_attempt < limit:
        wave = range(next_attempt, min(next_attempt + episodes - len(demos), limit))
        tasks = [DemoAttempt(spec_json, str(task), robot, policy_name, policy_values, max_actions, seed, attempt)
                 for attempt in wave]
        for result in executor.map(record_attempt, tasks):
            env_args = env_args or result.env_args
            if result.demo is None:
                discarded += 1
                log(f"attempt {result.attempt}: {result.start_name}: {result.problem}; discarded")
                continue
            demo = result.demo
            log(f"demo_{len(demos)}: {result.start_name}: {len(demo.attrs['plan'])} actions, "
                f"{demo.num_samples} control steps in {result.seconds:.1f} s")
            demos.append(demo)
        next_attempt = wave.stop
    attrs = {"task_spec": spec.to_dict(), "action_names": list(model.action_names), "policy": policy_name,
             "seed": seed, "discarded": discarded}
    if policy_name == "learned":
        attrs.update(learner=LEARNER, reward=REWARD, iterations=iterations, runs=runs,
                     learned_policy=json.dumps([int(a) for a in policy]))
    return demos, env_args, attrs


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code (see the module doc)."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    from tableclean_suite.bench.fidelity import physical_model
    from tableclean_suite.demos import write_dataset

    spec = physical_model(parser, args.task).spec
    robot = cli.parse_robot(parser, args)
    out = Path(args.out if args.out is not None else f"results/demos_{spec.name}_{args.policy}.hdf5")
    if out.is_dir():
        parser.error(f"--out {str(out)!r} is a directory; give a file name ending in .hdf5")
    try:
        import h5py  # noqa: F401
    except ImportError:
        parser.error("collecting demos needs h5py: pip install 'tableclean_suite[demos]' (or pip install h5py)")
    executor = cli.executor_from_args(parser, args)
    out.parent.mkdir(parents=True, exist_ok=True)

    from tableclean_suite.executors import MissingRayError, TaskFailedError

    started = time.perf_counter()
    try:
        with executor:
            demos, env_args, attrs = collect(args.task, args.episodes, robot, args.policy, args.seed,
                                             args.iterations, args.runs, args.max_actions, executor=executor)
    except (MissingRayError, ConnectionError) as error:  # no Ray, or no cluster at --ray-address
        parser.error(f"--executor {args.executor}: {error}")
    except TaskFailedError as error:
        print(f"{parser.prog}: {error}", file=sys.stderr)
        return 1
    if not demos:
        print(f"no successful demo in {args.episodes * MAX_ATTEMPTS_PER_EPISODE} attempts; nothing written",
              file=sys.stderr)
        return 1
    write_dataset(out, demos, env_args, attrs, valid_fraction=args.valid_fraction, seed=args.seed)
    total = sum(d.num_samples for d in demos)
    print(f"wrote {out}: {len(demos)} demo(s), {total} samples ({attrs['discarded']} attempt(s) discarded) "
          f"in {time.perf_counter() - started:.0f} s")
    if len(demos) < args.episodes:
        print(f"only {len(demos)} of {args.episodes} demos succeeded", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("demos", "python -m tableclean_suite.bench.collect_demos"))
