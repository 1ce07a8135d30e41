"""``tableclean-bench tune``: search a learner's hyperparameters with Optuna (TPE + median pruning).

    tableclean-bench tune --trials 40 --learner q_learning --reward r4
    tableclean-bench tune --trials 20          # a second call resumes the same study

Searches alpha, gamma, epsilon and the exploration schedule (constant, linear or exponential decay
to a floor) of one learner on one reward pattern and task.  The objective (minimised, iterations,
[`objective_value`][tableclean_suite.bench.tune.objective_value]) is the restricted mean of the runs'
learning times, penalised when the success asymptote falls more than ``--tolerance`` below the paper
configuration's.  A trial trains in `STAGES` stages of runs; Optuna's median pruner may stop it after each.

The study lives in ``--storage`` (default ``sqlite:///OUT/study.db``), so a call resumes it and several
processes can share it.  Each call publishes ``OUT/best.json`` and ``OUT/trials.csv``, also after Ctrl-C
(the finished trials; exit 130); ``--ablation`` adds ``OUT/ablation.csv``.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import time
from pathlib import Path

import numpy as np

from tableclean_suite.bench import cli
from tableclean_suite.bench.cli import EXIT_INTERRUPTED, EXIT_USAGE, say

#: Exploration schedules searched (``train(exploration=...)`` names) and the search ranges.
SCHEDULES = ("epsilon_greedy", "linear_decay", "exponential_decay")
ALPHA_RANGE = (0.05, 1.0)
GAMMA_RANGE = (0.0, 0.99)
EPSILON_RANGE = (0.01, 0.3)
EPSILON_MIN_RANGE = (0.0, 0.1)
#: Decay horizon / time constant as a fraction of the training window.
DECAY_FRACTION_RANGE = (0.05, 1.0)
#: The paper's configuration, the reference of the success constraint.
PAPER_SETTINGS = {"alpha": 0.3, "gamma": 0.3, "epsilon": 0.1, "exploration": "epsilon_greedy"}
#: Stages of runs per trial (intermediate values for the pruner).
STAGES = 4
#: (state, action) pairs per second of one exact asymptote analysis, for the time estimate.
ANALYSIS_PAIRS_PER_SECOND = 6_000_000
DEFAULT_TOLERANCE = 0.01
#: Study user attributes: the paper configuration's result, the configuration the study was made for.
REFERENCE_ATTR = "paper_reference"
CONFIGURATION_ATTR = "configuration"
OBJECTIVE = "learning_time_rmst"
#: The command-line settings a study's trials depend on (recorded in the study and in ``best.json``).
SETTINGS = ("learner", "reward", "runs", "iterations", "max_itr", "seed", "threshold", "tolerance", "ties")
ABLATION_LEVELS = ("paper", "tuned")
PROG = "tableclean-bench tune"
DEFAULT_OUT = "results/tune"


class StudyError(ValueError):
    """A study that cannot be opened or does not belong to this call's configuration (one line)."""


def study_configuration(args) -> dict:
    """What a study's trials depend on: the settings, the task spec, the objective, and the digests of the
    arrays the learner reads and of the code (``--plugins`` included)."""
    from tableclean_suite.bench.digests import code_digest, task_digest

    return {**{key: getattr(args, key) for key in SETTINGS}, "task": args.model.spec.to_dict(), "objective": OBJECTIVE,
            "task_digest": task_digest(args.model), "code_digest": code_digest(getattr(args, "plugins", ()))}


def bind_configuration(study, args) -> None:
    """Record this call's configuration in a new study; [`StudyError`][tableclean_suite.bench.tune.StudyError]
    naming the differences for a study made for another one (or with trials of an unrecorded one)."""
    wanted = json.loads(json.dumps(study_configuration(args)))
    stored = study.user_attrs.get(CONFIGURATION_ATTR)
    if stored is None:
        if study.trials or study.user_attrs.get(REFERENCE_ATTR) is not None:
            raise StudyError(f"study {args.study_name!r} in {args.storage} has {len(study.trials)} trials of an "
                             "unrecorded configuration; use another --study-name")
        study.set_user_attr(CONFIGURATION_ATTR, wanted)
        return
    if stored != wanted:
        keys = sorted(k for k in set(stored) | set(wanted) if stored.get(k) != wanted.get(k))
        shown = {k: ("<spec>" if k == "task" else None) for k in keys}
        before = ", ".join(f"{k}={shown[k] or stored.get(k)!r}" for k in keys)
        now = ", ".join(f"{k}={shown[k] or wanted.get(k)!r}" for k in keys)
        raise StudyError(f"study {args.study_name!r} in {args.storage} was created with {before}; this call asks "
                         f"for {now}; use another --study-name (or the study's settings)")


def check_resources(args) -> None:
    """Refuse, before any table is built or trial trains, a study whose stage (one stage's runs of the learner
    and its asymptote analysis) cannot fit in memory or whose trials and paper reference would run too long.

    Raises:
        tableclean_suite.resources.ResourceError: one line naming the estimate and the override.
    """
    from tableclean_suite import resources
    from tableclean_suite.asymptotes import EXACT_BYTES_PER_ENTRY
    from tableclean_suite.learners import get_learner
    from tableclean_suite.learners.memory import learner_training_memory
    from tableclean_suite.learners.rules import METHOD_DOUBLE_Q

    model, learner = args.model, get_learner(args.learner)
    pairs = model.n_states * model.n_actions
    stage_runs = -(-args.runs // STAGES)
    memory = learner_training_memory(model, learner, stage_runs, args.iterations)
    memory += resources.MemoryEstimate({"asymptote analysis": pairs * EXACT_BYTES_PER_ENTRY})
    resources.require_memory(memory, f"a tuning stage of {args.learner!r} on task {model.spec.name!r} "
                                     f"({model.n_states} states x {model.n_actions} actions, {stage_runs} runs x "
                                     f"{args.iterations} iterations)")
    evaluations = args.trials + 1  # the trials and the paper configuration's reference
    analyses = evaluations * STAGES
    resources.require_training_time(
        evaluations * args.runs, args.iterations, model.n_states, model.n_actions,
        f"tuning {args.trials} trial(s) of {args.learner!r} on task {model.spec.name!r}",
        planning_steps=learner.planning_steps, q_tables=1 + (learner.method == METHOD_DOUBLE_Q),
        extra_seconds=analyses * args.max_itr * pairs / ANALYSIS_PAIRS_PER_SECOND,
        extra_detail=f"{analyses} asymptote analyses of {args.max_itr} x {pairs} pairs at "
                     f"{ANALYSIS_PAIRS_PER_SECOND:.3g}/s")


def trial_settings(trial) -> dict:
    """The hyperparameters of an Optuna trial: alpha, gamma, epsilon and the exploration schedule."""
    settings = {
        "alpha": trial.suggest_float("alpha", *ALPHA_RANGE),
        "gamma": trial.suggest_float("gamma", *GAMMA_RANGE),
        "epsilon": trial.suggest_float("epsilon", *EPSILON_RANGE, log=True),
        "exploration": trial.suggest_categorical("exploration", SCHEDULES),
    }
    if settings["exploration"] != "epsilon_greedy":
        settings["epsilon_min"] = trial.suggest_float("epsilon_min", *EPSILON_MIN_RANGE)
        settings["decay_fraction"] = trial.suggest_float("decay_fraction", *DECAY_FRACTION_RANGE, log=True)
    return settings


def exploration_of(settings: dict, iterations: int):
    """``train(exploration=...)`` and the epsilon of the final behaviour for ``settings``."""
    name = settings["exploration"]
    if name == "epsilon_greedy":
        return None, settings["epsilon"]
    from tableclean_suite.learners.exploration import as_exploration

    floor = min(settings["epsilon_min"], settings["epsilon"])
    span = max(1, round(settings["decay_fraction"] * iterations))
    if name == "linear_decay":
        exploration = {"name": name, "epsilon_min": floor, "horizon": int(span)}
    else:
        exploration = {"name": name, "epsilon_min": floor, "rate": 1.0 / span}
    final = float(as_exploration(exploration).parameter_at(settings["epsilon"], iterations))
    return exploration, final


class Evaluation:
    """Trains one configuration stage by stage and scores it (see the module docstring)."""

    def __init__(self, args, settings: dict):
        from tableclean_suite import asymptotes
        from tableclean_suite.curves import CurveSums

        self.args, self.settings = args, settings
        self.exploration, self.final_epsilon = exploration_of(settings, args.iterations)
        self.chain = asymptotes.EpisodeChain.build(args.model, args.reward)
        self.sums = CurveSums.zeros(args.iterations)
        self.success: list[np.ndarray] = []
        self.learned_at: list[np.ndarray] = []

    def stages(self):
        """Train the runs in `STAGES` stages; yields the stage's index after each."""
        from tableclean_suite import asymptotes
        from tableclean_suite.learners import train

        bounds = np.linspace(0, self.args.runs, STAGES + 1).round().astype(int)
        for step, (lo, hi) in enumerate(zip(bounds[:-1], bounds[1:])):
            if hi <= lo:
                continue
            result = train(self.args.learner, self.args.reward, runs=int(hi - lo), first_run=int(lo),
                           iterations=self.args.iterations, alpha=self.settings["alpha"],
                           gamma=self.settings["gamma"], epsilon=self.settings["epsilon"], max_itr=self.args.max_itr,
                           seed=self.args.seed, task=self.args.model, exploration=self.exploration,
                           ties=self.args.ties)
            self.sums.add(result)
            self.learned_at.append(np.asarray(result.learned_at))
            final = asymptotes.greedy_asymptotes(result.q, self.final_epsilon, self.chain, self.args.max_itr)
            self.success.append(np.asarray(final.success))
            yield step

    def result(self) -> dict:
        """The runs so far: ``learning_time_rmst``, ``learning_time`` (Kaplan-Meier median, ``inf`` when
        censored) with ``_low``/``_high``, ``censored_share``, ``success_asymptote``, ``max_success_iterations``."""
        from tableclean_suite import metrics
        from tableclean_suite.learning_time import learning_time_summary

        asymptote = float(np.concatenate(self.success).mean())
        curve = self.sums.curves()["success"]
        reached = metrics.iterations_to_max_success(curve, self.args.threshold, top=asymptote)
        summary = learning_time_summary(np.concatenate(self.learned_at), self.args.iterations)
        return {"learning_time_rmst": summary.rmst, "learning_time": summary.median,
                "learning_time_low": summary.median_low, "learning_time_high": summary.median_high,
                "censored_share": summary.censored_share, "success_asymptote": asymptote,
                "max_success_iterations": reached}

    def finished(self) -> dict:
        """Train every stage; the result with infinite or NaN values as None (strict JSON)."""
        for _ in self.stages():
            pass
        return {key: _finite_or_none(value) for key, value in self.result().items()}


def objective_value(result: dict, reference: float | None, iterations: int, tolerance: float) -> float:
    """The minimised score: the restricted mean learning time (iterations), or ``iterations x
    (1 + shortfall)`` when the success asymptote falls short of ``reference - tolerance``."""
    value = float(result["learning_time_rmst"])
    if reference is not None and result["success_asymptote"] < reference - tolerance:
        value = iterations * (1.0 + (reference - result["success_asymptote"]))
    return value


def _reference(study, args) -> dict:
    """The paper configuration's result, computed once per study and stored as a user attribute."""
    if study.user_attrs.get(REFERENCE_ATTR) is None:
        study.set_user_attr(REFERENCE_ATTR, Evaluation(args, dict(PAPER_SETTINGS)).finished())
    return study.user_attrs[REFERENCE_ATTR]


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line."""
    from tableclean_suite.learners.rules import TIES

    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    parser.add_argument("--trials", type=cli.non_negative_int, default=30,
                        help="trials to add to the study (default: 30)")
    parser.add_argument("--learner", default="q_learning", help="registered learner (default: q_learning)")
    parser.add_argument("--reward", default="r4", help="registered reward pattern (default: r4)")
    cli.add_task_argument(parser)
    cli.add_runs_argument(parser, 200, "runs per trial")
    cli.add_iterations_argument(parser, 2000, "iterations per run")
    parser.add_argument("--max-itr", type=int, default=500, help="episode length limit (default: 500)")
    parser.add_argument("--threshold", type=float, default=0.95,
                        help="fraction of the success asymptote that counts as reached (default: 0.95)")
    parser.add_argument("--tolerance", type=cli.number_type(float, lambda v: 0 <= v <= 1, "a number in [0, 1]"),
                        default=DEFAULT_TOLERANCE,
                        help="allowed shortfall of the success asymptote below the paper configuration's "
                             f"(absolute fraction, default: {DEFAULT_TOLERANCE})")
    parser.add_argument("--ties", choices=tuple(TIES), default="random",
                        help="how the greedy policy breaks ties between equal Q values: the first in the task's "
                             "order or at random among them (default: random)")
    parser.add_argument("--ablation", action="store_true",
                        help="after the trials, cross the best trial's (alpha, gamma) and exploration with the "
                             "paper's (2 x 2) and write OUT/ablation.csv")
    cli.add_seed_argument(parser, "the training runs and of the sampler")
    cli.add_out_argument(parser, cli.DIRECTORY, DEFAULT_OUT, "output directory")
    parser.add_argument("--storage", default=None,
                        help="Optuna storage URL (default: sqlite:///OUT/study.db); share it to tune from several "
                             "processes or machines")
    parser.add_argument("--study-name", default=None,
                        help="study name (default: LEARNER-REWARD-TASK-RUNSxITERATIONS)")
    return parser


def parse_args(argv=None, prog: str | None = None) -> argparse.Namespace:
    """Parse and check the command line; a bad value exits 2 naming it."""
    from tableclean_suite.bench.config import ConfigError, RunConfig

    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    args.prog = parser.prog
    cli.check_out(parser, args.out, "tune")
    try:
        config = RunConfig(learners=(args.learner,), rewards=(args.reward,), runs=args.runs, iterations=args.iterations,
                           max_itr=args.max_itr, seed=args.seed, task=args.task, threshold=args.threshold,
                           sweep_learner=args.learner, sweep_reward=args.reward, sweeps=False,
                           plugins=args.plugins)
    except ConfigError as error:  # the run's list fields are this command's single --learner and --reward
        flag = {"learners": "--learner", "rewards": "--reward"}.get(error.field, "--" + error.field.replace("_", "-"))
        parser.error(error.message_for(flag))
    args.model = config.task_model()
    out = Path(args.out)
    args.storage = args.storage or f"sqlite:///{(out / 'study.db').as_posix()}"
    args.study_name = (args.study_name
                       or f"{args.learner}-{args.reward}-{Path(args.task).stem}-{args.runs}x{args.iterations}")
    return args


def trials_frame(study):
    """One row per trial: number, state, value, hyperparameters (``param_*``) and measured results."""
    frame = study.trials_dataframe(attrs=("number", "state", "value", "params", "user_attrs"))
    return frame.rename(columns=lambda name: name.replace("params_", "param_", 1).removeprefix("user_attrs_"))


def best_report(study, args) -> dict:
    """``best.json``: the best trial's configuration and results beside the paper configuration's."""
    from optuna.trial import TrialState

    reference = study.user_attrs.get(REFERENCE_ATTR)
    completed = study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,))
    best = study.best_trial if completed else None
    return {
        "study": args.study_name, "storage": args.storage, "task": args.task, **{k: getattr(args, k) for k in SETTINGS},
        "trials": len(study.trials), "completed": len(completed),
        "pruned": len(study.get_trials(deepcopy=False, states=(TrialState.PRUNED,))),
        "objective": "restricted mean per-run learning time up to the budget (iterations); iterations x "
                     "(1 + shortfall) when the success asymptote is more than tolerance below the paper "
                     "configuration's",
        "paper": {"settings": PAPER_SETTINGS, **(reference or {}),
                  "objective": None if reference is None else objective_value(reference, None, args.iterations, 0.0)},
        "best": None if best is None else {"trial": best.number, "objective": best.value, "settings": best.params,
                                           **best.user_attrs},
    }


def run(args) -> int:
    """Run the trials, then publish ``trials.csv``, ``best.json`` (and ``ablation.csv``) into ``--out``;
    after Ctrl-C the finished trials are published and the exit code is 130."""
    import optuna

    from tableclean_suite.bench import outputs

    prog, out = getattr(args, "prog", PROG), Path(args.out)
    optuna.logging.set_verbosity(optuna.logging.ERROR)  # the trial Ctrl-C stopped is reported once, without a traceback
    check_resources(args)
    try:
        study = open_study(args)
    except StudyError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return EXIT_USAGE
    started = time.perf_counter()
    reference = _reference(study, args)

    def objective(trial):
        evaluation = Evaluation(args, trial_settings(trial))
        for step in evaluation.stages():
            value = objective_value(evaluation.result(), reference["success_asymptote"], args.iterations,
                                    args.tolerance)
            trial.report(value, step)
            if trial.should_prune():
                raise optuna.TrialPruned()
        result = evaluation.result()
        for key, value in result.items():
            trial.set_user_attr(key, _finite_or_none(value))
        trial.set_user_attr("final_epsilon", evaluation.final_epsilon)
        return objective_value(result, reference["success_asymptote"], args.iterations, args.tolerance)

    try:
        study.optimize(objective, n_trials=args.trials)
        interrupted = False
    except KeyboardInterrupt:
        interrupted = True
    report = best_report(study, args)
    paper, best = report["paper"], report["best"]
    trials = trials_frame(study)
    writers = {"trials.csv": lambda path: trials.to_csv(path, index=False),
               "best.json": lambda path: path.write_text(json.dumps(report, indent=2,  # numpy scalars: .item()
                                                                    default=lambda value: value.item()))}
    rows = []
    if args.ablation and not interrupted:
        if best is None:
            print(f"{prog}: error: --ablation needs a completed trial; the study has none", file=sys.stderr)
            return EXIT_USAGE
        import pandas as pd

        rows = ablation(args, best["settings"])
        writers["ablation.csv"] = lambda path: pd.DataFrame(rows).to_csv(path, index=False)
    # after Ctrl-C, a second one must not stop the publication of the finished trials
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if interrupted else None
    try:
        written = outputs.publish(out, writers, {"args": outputs.arguments(args)}, command="tune", kept=("study.db",))
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    if interrupted:
        print(f"{prog}: interrupted; the {report['completed']} completed trials are published in "
              f"{out / 'trials.csv'} and {out / 'best.json'}", file=sys.stderr)
        return EXIT_INTERRUPTED
    say(f"study {args.study_name!r} in {args.storage}: {report['trials']} trials ({report['completed']} complete, "
          f"{report['pruned']} pruned), {time.perf_counter() - started:.1f} s this call")
    say(f"objective: restricted mean per-run learning time up to {args.iterations} iterations ({args.runs} runs, "
          f"greedy ties: {args.ties})")
    say(f"paper (alpha = gamma = 0.3, epsilon = 0.1): {result_text(paper)}")
    if best is not None:
        say(f"best trial {best['trial']}: objective {best['objective']:.0f}, {result_text(best)}, "
            f"settings {best['settings']}")
    if rows:
        say(f"ablation ({args.learner}, {args.reward}, {args.runs} runs x {args.iterations} iterations, seed "
            f"{args.seed}, greedy ties: {args.ties}):")
        for row in rows:
            say(f"  alpha, gamma {row['alpha_gamma']:<6} x exploration {row['exploration_from']:<6}: "
                f"{result_text(row)}")
    say(f"written: {', '.join(str(path) for path in written)}")
    return 0


def _finite_or_none(value):
    return None if isinstance(value, float) and not np.isfinite(value) else value


def result_text(result: dict) -> str:
    """One line of an [`Evaluation.result`][tableclean_suite.bench.tune.Evaluation.result] (or a stored copy)."""
    def number(key):
        value = result.get(key)
        return "censored" if value is None or not np.isfinite(value) else f"{value:.0f}"

    return (f"median learning time {number('learning_time')} [{number('learning_time_low')}, "
            f"{number('learning_time_high')}] iterations, {100 * result.get('censored_share', float('nan')):.1f} % "
            f"censored, restricted mean {number('learning_time_rmst')}, success asymptote "
            f"{100 * result.get('success_asymptote', float('nan')):.2f} %, paper's first touch "
            f"{result.get('max_success_iterations')}")


def ablation_settings(tuned: dict) -> list[tuple[str, str, dict]]:
    """The 2 x 2 crossing of (alpha, gamma) with the exploration (epsilon, schedule and its parameters):
    ``[(alpha_gamma level, exploration level, settings)]``, levels ``paper``/``tuned``."""
    source = {"paper": PAPER_SETTINGS, "tuned": tuned}
    return [(values, explore, {**{k: v for k, v in source[explore].items() if k not in ("alpha", "gamma")},
                               "alpha": source[values]["alpha"], "gamma": source[values]["gamma"]})
            for values in ABLATION_LEVELS for explore in ABLATION_LEVELS]


def ablation(args, tuned: dict) -> list[dict]:
    """Train every combination of [`ablation_settings`][tableclean_suite.bench.tune.ablation_settings] on the
    study's runs; one row each."""
    return [{"alpha_gamma": values_from, "exploration_from": exploration_from, "ties": args.ties,
             **{f"setting_{key}": value for key, value in settings.items()},
             **Evaluation(args, settings).finished()}
            for values_from, exploration_from, settings in ablation_settings(tuned)]


def open_study(args):
    """The study of ``args``, created or resumed and bound to its configuration;
    [`StudyError`][tableclean_suite.bench.tune.StudyError] when ``--storage`` cannot be opened or the study
    belongs to another configuration."""
    import optuna

    try:
        study = optuna.create_study(
            study_name=args.study_name, storage=args.storage, direction="minimize", load_if_exists=True,
            pruner=optuna.pruners.MedianPruner(n_startup_trials=5, n_warmup_steps=1),
        )
        # seeded past the trials so far: a resumed call does not replay the first call's proposals
        study.sampler = optuna.samplers.TPESampler(seed=args.seed + len(study.trials))
    except Exception as error:  # any storage backend's failure (sqlalchemy, a missing driver, optuna)
        reason = (str(error).strip().splitlines() or [type(error).__name__])[0]
        raise StudyError(f"--storage {args.storage!r} cannot be opened: {type(error).__name__}: {reason}") from None
    bind_configuration(study, args)
    return study


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    return run(parse_args(argv, prog))


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("tune", "python -m tableclean_suite.bench.tune"))
