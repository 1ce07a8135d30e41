"""``tableclean-bench interventions``: change one factor of a cell and measure what it does.

    tableclean-bench interventions                              # every intervention, 200 runs per arm
    tableclean-bench interventions --only q_init,routine_reward --runs 100 --out results/interventions

Each [`Intervention`][tableclean_suite.bench.interventions.Intervention] tests an explanation of the
findings page: it trains a *before* cell and an *after* cell differing in the one factor the
explanation names, on the same runs, and reports for both the per-run learning time (Kaplan-Meier
median, share censored), the success plateau (exact, of each run's final behaviour) and the share
of runs never terminal, each with a 95 % interval, and whether the predicted figure moved
([observed_change][tableclean_suite.bench.interventions.observed_change]).  Writes
``OUT/interventions.csv`` (one row per arm); deterministic for a given ``--seed``.  ``--scale``
multiplies every budget (a quick look).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tableclean_suite.bench.cli import say
from tableclean_suite.intervals import DEFAULT_CONFIDENCE as CONFIDENCE

PROG = "tableclean-bench interventions"
DEFAULT_OUT = "results/interventions"
DEFAULT_RUNS = 200
#: The paper's settings every cell starts from (alpha, gamma, epsilon, max_itr; the paper task).
BASE = {"learner": "q_learning", "alpha": 0.3, "gamma": 0.3, "epsilon": 0.1, "max_itr": 500, "iterations": 4000,
        "task": "paper", "q_init": None}
#: Figures a prediction can name, and the text they print as.
FIGURES = {"learning_time": "median learning time", "censored_share": "censored share",
           "success_plateau": "success plateau", "never_terminal_share": "never-terminal share"}


def _pattern(base: str, name: str, **changes):
    """Reward pattern ``base`` with ``changes`` (a new, unregistered pattern called ``name``)."""
    from tableclean_suite.rewards import get_reward_pattern

    return dataclasses.replace(get_reward_pattern(base), name=name, **changes)


@dataclass(frozen=True)
class Intervention:
    """One causal check ``name``: the ``claim`` it tests, the one ``factor`` changed, the ``train()`` settings of
    the ``before`` arm (over `BASE`) and those the ``after`` arm changes, and the ``figure`` (a key of
    `FIGURES`) the claim predicts to fall (``direction`` -1) or rise (+1)."""

    name: str
    claim: str
    factor: str
    before: dict
    after: dict
    figure: str
    direction: int

    def settings(self, arm: str, scale: float = 1.0) -> dict:
        """The full ``train()`` settings of ``arm`` (``"before"``/``"after"``), budget x ``scale``."""
        chosen = {**BASE, **self.before, **(self.after if arm == "after" else {})}
        chosen["iterations"] = max(1, round(chosen["iterations"] * scale))
        return chosen


def interventions() -> dict[str, Intervention]:
    """Every intervention, by name, in the order the findings page cites them."""
    from tableclean_suite.bench.scaling.family import family_spec

    r3_zero_routine = _pattern("r3", "r3_routine_0", routine=0.0)
    r4_any_cycle = _pattern("r4", "r4_memory_0", looping_memory=0)
    listed = [
        Intervention("q_init", "r3's runs that never find the terminal state keep a routine loop because Q starts "
                     "at 0 and the loop's +0.01 per step beats every untried action",
                     "initial Q values (optimistic: an untried action beats the loop)",
                     {"reward": "r3", "gamma": 0.9}, {"q_init": 1.0}, "censored_share", -1),
        Intervention("routine_reward", "the routine reward (+0.01 per move, pick or place) is what makes r3's "
                     "loop worth keeping", "r3's routine reward",
                     {"reward": "r3", "gamma": 0.9}, {"reward": r3_zero_routine}, "censored_share", -1),
        Intervention("gamma_r3", "r3's loop is worth 0.01 / (1 - gamma), so a longer horizon makes r3 worse, "
                     "not better", "gamma", {"reward": "r3", "gamma": 0.3}, {"gamma": 0.9},
                     "censored_share", +1),
        Intervention("max_itr", "r3's trap is a loop kept within long episodes: shorter episodes restart the "
                     "run from the start state more often", "episode length limit (max_itr)",
                     {"reward": "r3", "gamma": 0.9}, {"max_itr": 50}, "censored_share", -1),
        Intervention("budget_r3", "r3's failure shrinks only slowly with the budget",
                     "budget length", {"reward": "r3", "gamma": 0.3}, {"iterations": 36000},
                     "censored_share", -1),
        Intervention("loop_memory", "with 3 or more segments the paper's looping rule misses MOVE going round the "
                     "ring of segments, so r4 earns the routine reward for cycling",
                     "the looping rule's memory (2 states, the paper's, or the whole episode)",
                     {"reward": "r4", "gamma": 0.9, "task": family_spec(3, 1), "iterations": 32000, "max_itr": 688},
                     {"reward": r4_any_cycle}, "censored_share", -1),
        Intervention("epsilon", "the success plateau is the optimal plan's exploration cost: a converged run "
                     "scores what its random actions allow", "epsilon", {"reward": "r4"},
                     {"epsilon": 0.01}, "success_plateau", +1),
        Intervention("gamma_sarsa", "SARSA fails at gamma 0.3 because its on-policy fixed point there steers away "
                     "from the object, not because it learns slowly", "gamma",
                     {"learner": "sarsa", "reward": "r1"}, {"gamma": 0.5}, "censored_share", -1),
        Intervention("budget_sarsa", "SARSA at gamma 0.9 is slower, not wrong: given a longer budget its runs "
                     "learn the optimal plan", "budget length",
                     {"learner": "sarsa", "reward": "r1", "gamma": 0.9}, {"iterations": 36000}, "censored_share",
                     -1),
    ]
    return {item.name: item for item in listed}


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line."""
    from tableclean_suite.bench import cli

    parser = cli.command_parser(prog, __doc__.splitlines()[0].split(": ", 1)[1])
    known = tuple(interventions())
    parser.add_argument("--only", type=cli.choice_list(known, "intervention"), default=known,
                        help=f"comma-separated interventions to run; allowed: {', '.join(interventions())} "
                             "(default: all)")
    cli.add_runs_argument(parser, DEFAULT_RUNS, "runs per arm")
    parser.add_argument("--scale", type=cli.number_type(float, lambda v: 0 < v <= 1, "a budget scale in (0, 1]"),
                        default=1.0,
                        help="multiply every arm's budget (iterations) by this, in (0, 1] (default: 1)")
    cli.add_seed_argument(parser, "the training runs and the plateau's bootstrap")
    cli.add_out_argument(parser, cli.DIRECTORY, DEFAULT_OUT, "output folder")
    return parser


def _setting_text(value) -> str:
    return value.name if hasattr(value, "name") and not isinstance(value, (int, float, str)) else str(value)


def measure_arm(settings: dict, runs: int, seed: int) -> dict:
    """Train one arm: its figures (learning time, censored share, plateau, never terminal) and intervals."""
    from tableclean_suite import asymptotes
    from tableclean_suite.intervals import clopper_pearson, interval_estimates
    from tableclean_suite.learning_time import learning_time_summary
    from tableclean_suite.learners import train
    from tableclean_suite.task import Outcome, TaskModel

    started = time.perf_counter()
    model = TaskModel(spec=settings["task"])
    result = train(settings["learner"], settings["reward"], runs=runs, iterations=settings["iterations"],
                   alpha=settings["alpha"], gamma=settings["gamma"], epsilon=settings["epsilon"],
                   max_itr=settings["max_itr"], seed=seed, task=model, q_init=settings["q_init"])
    summary = learning_time_summary(result.learned_at, settings["iterations"], CONFIDENCE,
                                    rng=np.random.default_rng(seed))
    chain = asymptotes.EpisodeChain.build(model, settings["reward"])
    plateau = np.asarray(asymptotes.greedy_asymptotes(result.q, settings["epsilon"], chain,
                                                      settings["max_itr"]).success, dtype=float)
    points, bounds = interval_estimates({"plateau": plateau}, np.mean, CONFIDENCE, rng=np.random.default_rng(seed))
    never = int(np.sum(~(np.asarray(result.outcomes) == int(Outcome.TERMINAL)).any(axis=1)))
    return {
        "learning_time": summary.median, "learning_time_low": summary.median_low,
        "learning_time_high": summary.median_high, "learning_time_rmst": summary.rmst,
        "censored_share": summary.censored_share,
        **_bounds("censored_share", (summary.censored_low, summary.censored_high)),
        "success_plateau": points["plateau"], **_bounds("success_plateau", bounds["plateau"]),
        "never_terminal_share": never / runs,
        **_bounds("never_terminal_share", clopper_pearson(never, runs, CONFIDENCE)),
        "seconds": time.perf_counter() - started,
    }


def _bounds(name: str, interval) -> dict:
    return {f"{name}_low": float(interval[0]), f"{name}_high": float(interval[1])}


#: The observed changes of a predicted figure ([observed_change][tableclean_suite.bench.interventions.observed_change]).
PREDICTED, OPPOSITE, NO_CLEAR_CHANGE = "in the predicted direction", "in the opposite direction", "no clear change"


def observed_change(item: Intervention, before: dict, after: dict) -> str:
    """How ``item``'s predicted figure moved between the arms' figures (as
    [measure_arm][tableclean_suite.bench.interventions.measure_arm]): `PREDICTED` when the after arm's
    interval lies wholly on the predicted side of the before arm's, `OPPOSITE` when wholly on the other
    side, `NO_CLEAR_CHANGE` when they overlap (a learning time's non-finite upper end is unbounded)."""
    name = item.figure
    low_b, high_b = before[f"{name}_low"], before[f"{name}_high"]
    low_a, high_a = after[f"{name}_low"], after[f"{name}_high"]
    if name == "learning_time":  # a censored median: the interval reaches past the budget
        high_b, high_a = (math.inf if not math.isfinite(h) else h for h in (high_b, high_a))
    if high_a < low_b:
        return PREDICTED if item.direction < 0 else OPPOSITE
    if low_a > high_b:
        return PREDICTED if item.direction > 0 else OPPOSITE
    return NO_CLEAR_CHANGE


def _interval_text(arm: dict, name: str, budget: int | None = None) -> str:
    """``"value [low, high]"`` of an arm's figure ``name``: a share in %, or with ``budget`` a time in
    iterations (an infinite one reads ``>budget``)."""
    def number(value):
        if budget is None:
            return f"{100 * value:.1f}"
        return f">{budget}" if not math.isfinite(value) else f"{value:.0f}"

    return f"{number(arm[name])} [{number(arm[name + '_low'])}, {number(arm[name + '_high'])}]"


def changed_text(before: dict, after: dict) -> str:
    """The settings that differ between two arms, e.g. ``"gamma 0.3 -> 0.9"``."""
    return ", ".join(f"{key} {_setting_text(before[key])} -> {_setting_text(after[key])}" for key in before
                     if _setting_text(before[key]) != _setting_text(after[key]))


def run(args) -> int:
    """Run the chosen interventions, print before/after and write ``interventions.csv``; returns 0."""
    import pandas as pd

    from tableclean_suite.bench import outputs

    known = interventions()
    started = time.perf_counter()
    rows = []
    with outputs.output_lock(args.out) as out:
        say(f"Interventions: {len(args.only)}, {args.runs} runs per arm, seed {args.seed}, budget scale "
            f"{args.scale:g}. Learning time: Kaplan-Meier median [95 % interval] in iterations; shares in % "
            "[95 % Clopper-Pearson]; success plateau in % [95 % bootstrap].")
        for name in args.only:
            item = known[name]
            predicted = f"{FIGURES[item.figure]} {'falls' if item.direction < 0 else 'rises'}"
            settings = {arm: item.settings(arm, args.scale) for arm in ("before", "after")}
            arms = {arm: measure_arm(chosen, args.runs, args.seed) for arm, chosen in settings.items()}
            change = observed_change(item, arms["before"], arms["after"])
            rows += [{"intervention": name, "arm": arm, "factor": item.factor, "claim": item.claim,
                      "predicted": predicted, **{key: _setting_text(value) for key, value in settings[arm].items()},
                      "runs": args.runs, "seed": args.seed, **arms[arm], "change": change} for arm in arms]
            before = settings["before"]
            say(f"\n{name}: {item.claim}.")
            say(f"  cell: {before['learner']}, {_setting_text(before['reward'])}, task "
                f"{_setting_text(before['task'])}, gamma {before['gamma']:g}, epsilon {before['epsilon']:g}, "
                f"max_itr {before['max_itr']}, {before['iterations']} iterations\n  changed: {item.factor} "
                f"({changed_text(before, settings['after'])})")
            for arm, figures in arms.items():
                learned = _interval_text(figures, "learning_time", settings[arm]["iterations"])
                say(f"  {arm:<6}: learning time {learned}, censored {_interval_text(figures, 'censored_share')}, "
                    f"plateau {_interval_text(figures, 'success_plateau')}, never terminal "
                    f"{_interval_text(figures, 'never_terminal_share')}")
            say(f"  predicted: {predicted}; observed: {change}")
        frame = pd.DataFrame(rows)
        outputs.publish(out, {"interventions.csv": lambda path: frame.to_csv(path, index=False)},
                        {"args": outputs.arguments(args)}, command="interventions")
    say(f"\nWrote {Path(args.out) / 'interventions.csv'} in {time.perf_counter() - started:.1f} s wall.")
    return 0


def main(argv=None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code."""
    from tableclean_suite.bench import cli

    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    cli.check_out(parser, args.out, "interventions")
    return run(args)


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("interventions", "python -m tableclean_suite.bench.interventions"))
