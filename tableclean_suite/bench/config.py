"""A benchmark run's configuration, `RunConfig`: every default of the run command, its help texts
(the field docstrings), validation, and what a cell's key holds (`RunConfig.cell_settings`).

    from tableclean_suite.bench.config import RunConfig
    config = RunConfig(runs=200, rewards=("r2", "r4"), sweeps=False)
"""

from __future__ import annotations

import ast
import inspect
import json
import math
from dataclasses import asdict, dataclass, fields
from typing import ClassVar

from tableclean_suite.analysis import ANALYSIS_KINDS
from tableclean_suite.backends import backend_names  # noqa: F401 (run's --backend choices)
from tableclean_suite.intervals import DEFAULT_CONFIDENCE, DEFAULT_REPS as DEFAULT_SAMPLES
from tableclean_suite.metrics import DEFAULT_PLATEAU_FRACTION, DEFAULT_THRESHOLD
from tableclean_suite.settling import DEFAULT_SETTLE_TOLERANCE
from tableclean_suite.simulation import SIMULATED_EPISODES
from tableclean_suite.task.spec import IneffectiveMode, StartMode, unique_keys

#: Largest ``bootstrap_samples``.
MAX_BOOTSTRAP_SAMPLES = 100_000

#: Episode start modes and ineffective-action modes a task spec can be overridden with.
START_MODES = tuple(mode.value for mode in StartMode)
INEFFECTIVE_MODES = tuple(mode.value for mode in IneffectiveMode)

#: Cruz et al.'s methods run on this task for Table 4's "run here" rows (``literature`` cells).
LITERATURE_LEARNERS = ("affordance_q_learning", "learned_affordance_q_learning", "interactive_q_learning")


class ConfigError(ValueError):
    """A field with a value it cannot take.

    Attributes:
        field: the `RunConfig` field.
        problem: what is wrong and what is allowed (the message is ``"field: problem"``, or the
            problem alone when it starts with the field's name).
    """

    def __init__(self, field: str, problem: str):
        self.field = field
        self.problem = problem
        super().__init__(self.message_for(field))

    def message_for(self, name: str) -> str:
        """The message with the field called ``name`` (e.g. its command-line flag)."""
        if self.problem.startswith(self.field + " "):
            return name + self.problem[len(self.field):]
        return f"{name}: {self.problem}"


@dataclass(frozen=True)
class RunConfig:
    """Everything that defines one benchmark run (the paper's Tables 3-4 and Figures 3-7)."""

    learners: tuple[str, ...] = ("q_learning", "sarsa")
    """Registered learners of the main cells (Table 3 rows), in table order."""
    rewards: tuple[str, ...] = ("r1", "r2", "r3", "r4")
    """Registered reward patterns of the main cells, in table order."""
    runs: int = 1000
    """Independent runs per cell, averaged into the curves; an integer in [1, 10**7]."""
    iterations: int = 4000
    """Environment steps per run (the length T of every curve); an integer in [1, 10**8]."""
    alpha: float = 0.3
    """Learning rate of the main cells, in (0, 1]."""
    gamma: float = 0.3
    """Discount factor of the main cells, in [0, 1]."""
    epsilon: float = 0.1
    """Epsilon-greedy exploration rate, in [0, 1] (the start value of an epsilon schedule)."""
    exploration: str = "epsilon_greedy"
    """Behaviour policy of every cell: a registered exploration, optionally with parameters as
    name:key=value,... (e.g. linear_decay:epsilon_min=0.01,horizon=2000); schedules start at
    --epsilon. The plateaus are the exact asymptotes of the final behaviour."""
    q_init: float | None = None
    """Initial value of every Q entry (any finite number; above the best return it is optimistic);
    default: each learner's own (0)."""
    learner_options: str | None = None
    """Update-rule and assistance options as JSON ({"planning_steps": 20}) or key=value,...
    (planning_steps=20,lambda_=0.8); each main and sweep learner gets the options it takes (an
    option none takes is an error); the literature cells keep Cruz et al.'s definitions."""
    max_itr: int = 500
    """Iterations after which an episode is truncated; an integer in [1, 10**8]."""
    seed: int = 0
    """Base seed, an integer >= 0; run i draws from the counter-based key of (seed, i)."""
    alpha_sweep: tuple[float, ...] = (0.3, 0.5, 0.7, 0.9)
    """Alphas of the alpha sweep (Figures 6-7), each in (0, 1], at gamma = --gamma."""
    gamma_sweep: tuple[float, ...] = (0.3, 0.5, 0.7, 0.9)
    """Gammas of the gamma sweep (Figures 6-7), each in [0, 1], at alpha = --alpha."""
    sweep_learner: str = "q_learning"
    """Registered learner of the sweeps."""
    sweep_reward: str = "r4"
    """Registered reward pattern of the sweeps."""
    sweeps: bool = True
    """Train the alpha and gamma sweeps."""
    literature: bool = True
    """Train Cruz et al.'s methods on this task (affordance-based and interactive Q-learning) at
    --literature-reward for Table 4's "run here" rows."""
    literature_reward: str = "r4"
    """Registered reward pattern of the literature cells."""
    task: str = "paper"
    """Task spec: a registered name or the path of a JSON spec file (tableclean_suite.task.TaskSpec)."""
    start: str | None = None
    """Episode start, overriding the task spec's: fixed (the spec's start state) or uniform_unclean
    (uniform over the all-unclean layouts with nothing held); default: as the task spec says."""
    ineffective: str | None = None
    """How a pick with nothing to pick or a place with nothing held counts, overriding the task
    spec's: ineffective or improper; default: as the task spec says."""
    threshold: float = DEFAULT_THRESHOLD
    """Fraction of the plateau that counts as reached, in (0, 1]."""
    plateau_fraction: float = DEFAULT_PLATEAU_FRACTION
    """Final fraction of the window averaged as the window mean (shown beside the plateau, which is
    the exact asymptote of the runs' final policies), in (0, 1]."""
    settle_tolerance: float = DEFAULT_SETTLE_TOLERANCE
    """Largest behaviour drift (mean per-run change of the success asymptote over the window's last
    quarter, a fraction) for which a cell counts as settled, in [0, 1]; cells above it are marked in
    Table 3 because their figures depend on the window (tableclean_suite.settling)."""
    support_fraction: float = 0.5
    """Fraction of the runs that must have finished an episode before an average-reward point counts, in [0, 1]."""
    bootstrap_samples: int = DEFAULT_SAMPLES
    """Bootstrap replicates behind each interval and band, an integer in [1, 100000]."""
    confidence: float = DEFAULT_CONFIDENCE
    """Coverage of the intervals, in (0, 1)."""
    analysis: str = "auto"
    """How each cell's plateaus are computed: exact (dynamic programming over the task), simulated
    (Monte Carlo episodes of each run's final policy, their error inside the intervals) or auto
    (simulated only where exact would cost over ten times the training and over a minute)."""
    analysis_episodes: int = SIMULATED_EPISODES
    """Episodes simulated per run and policy when the plateaus are simulated, an integer >= 2."""
    backend: str = "symbolic"
    """Training backend: symbolic model, calibrated transition table, or skills in MuJoCo physics."""
    transitions: str | None = None
    """Transition table JSON (from tableclean-bench calibrate); only with --backend calibrated."""
    workers: int | None = None
    """Workers, >= 1. Local executor: processes training one cell each with one compiled thread
    (1: cells in this process with one thread; physics backend: cells in this process, each cell's
    runs over this many processes); ray executor: most cells in flight. Default: cells in this
    process, compiled threads (physics: processes) on all cores; ray: as many as the cluster runs."""
    executor: str = "local"
    """Where cells train: local (this machine) or ray (a private Ray on loopback, or the cluster at
    --ray-address). Results are the same bit for bit whatever the executor, workers or threads."""
    ray_address: str | None = None
    """Ray cluster to run the cells on: HOST:PORT of its head (ray start --head) or auto; default:
    a private Ray on this machine. Only with --executor ray."""
    out: str = "results"
    """Output directory (created if missing)."""
    figures: bool = True
    """Draw the PNG figures."""
    fresh: bool = False
    """Retrain every cell and recompute the cached comparisons and figures, ignoring (and overwriting)
    the saved ones."""
    progress: bool = True
    """Show a progress bar over cells on stderr."""
    verbose: bool = False
    """Show the warnings robosuite logs when it is imported (physics backend)."""
    plugins: tuple[str, ...] = ()
    """Modules (names or .py paths) imported first, to register actions, learners, rewards, specs
    or objects; executor workers import them too."""

    #: Fields that never change a cell's numbers as such (the cell, the task, the table and the
    #: analysis enter its key by value, not by these names or paths).
    NOT_IN_CELL_KEY: ClassVar[tuple[str, ...]] = (
        "learners", "rewards", "alpha", "gamma", "alpha_sweep", "gamma_sweep", "sweep_learner", "sweep_reward",
        "sweeps", "literature", "literature_reward", "task", "transitions", "workers", "executor", "ray_address",
        "out", "figures", "fresh", "progress", "verbose", "plugins", "settle_tolerance", "analysis",
        "analysis_episodes",
    )
    def __post_init__(self):
        for name in ("learners", "rewards", "alpha_sweep", "gamma_sweep"):  # de-duplicated in order (values as floats)
            value = getattr(self, name)
            items = (value,) if isinstance(value, (str, int, float)) else tuple(value)
            if name.endswith("_sweep"):
                items = tuple(_number(name, v) for v in items)
            object.__setattr__(self, name, tuple(dict.fromkeys(items)))
            if not getattr(self, name):
                raise ConfigError(name, "give at least one value")
        self._validate()

    def _validate(self) -> None:
        from tableclean_suite.executors import EXECUTOR_NAMES
        from tableclean_suite.learners import learner_names, validate_hyperparameters
        from tableclean_suite.rewards import reward_pattern_names

        learners, rewards = learner_names(), reward_pattern_names()
        for name in ("learners", "sweep_learner"):
            _check_names(name, getattr(self, name), learners)
        for name in ("rewards", "sweep_reward", "literature_reward"):
            _check_names(name, getattr(self, name), rewards)
        self._validate_learning()
        hyper = dict(runs=self.runs, iterations=self.iterations, alpha=self.alpha, gamma=self.gamma,
                     epsilon=self.epsilon, max_itr=self.max_itr, seed=self.seed)
        _call(validate_hyperparameters, **hyper)
        for name, key in (("alpha_sweep", "alpha"), ("gamma_sweep", "gamma")):
            for value in getattr(self, name):
                _call(validate_hyperparameters, field=name, **{**hyper, key: value})
        for name, bounds in (("threshold", "(0, 1]"), ("plateau_fraction", "(0, 1]"), ("settle_tolerance", "[0, 1]"),
                             ("support_fraction", "[0, 1]"), ("confidence", "(0, 1)")):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and (0.0 < value if bounds[0] == "(" else 0.0 <= value)
                    and (value < 1.0 if bounds[-1] == ")" else value <= 1.0)):
                raise ConfigError(name, f"{name} must be in {bounds}, got {value!r}")
        _check_integer("bootstrap_samples", self.bootstrap_samples, 1, MAX_BOOTSTRAP_SAMPLES)
        _check_names("analysis", self.analysis, ANALYSIS_KINDS)
        _check_integer("analysis_episodes", self.analysis_episodes, 2)
        self.task_spec()
        for name, allowed in (("start", START_MODES), ("ineffective", INEFFECTIVE_MODES)):
            if getattr(self, name) is not None:
                _check_names(name, getattr(self, name), allowed)
        if self.workers is not None:
            _check_integer("workers", self.workers, 1)
        _check_names("executor", self.executor, EXECUTOR_NAMES)
        if self.ray_address is not None and self.executor != "ray":
            raise ConfigError("ray_address", "only used with executor ray")
        if self.ray_address is not None and (not isinstance(self.ray_address, str) or not self.ray_address.strip()):
            raise ConfigError("ray_address", f"give HOST:PORT or auto, got {self.ray_address!r}")
        _check_names("backend", self.backend, backend_names())
        if self.backend == "calibrated" and self.transitions is None:
            raise ConfigError("transitions", "needed by backend calibrated (a table from tableclean-bench calibrate)")
        if self.backend != "calibrated" and self.transitions is not None:
            raise ConfigError("transitions", "only used with backend calibrated")

    def _validate_learning(self) -> None:
        """Check and normalise ``exploration``, ``q_init`` and ``learner_options``."""
        from tableclean_suite.learners.exploration import parse_exploration

        if not isinstance(self.exploration, str):
            raise ConfigError("exploration", f"exploration must be text like linear_decay:horizon=2000, "
                                             f"got {self.exploration!r}")
        try:
            parse_exploration(self.exploration).check(float(self.epsilon))
        except ValueError as error:
            raise ConfigError("exploration", str(error)) from None
        if self.q_init is not None:
            object.__setattr__(self, "q_init", _number("q_init", self.q_init))
            if not math.isfinite(self.q_init):
                raise ConfigError("q_init", f"q_init must be a finite number, got {self.q_init!r}")
        options = parse_learner_options(self.learner_options)
        object.__setattr__(self, "learner_options", json.dumps(options, sort_keys=True) if options else None)
        taken = set()
        for name in self.trained_learners():
            try:
                self.learner(name)
            except ValueError as error:
                raise ConfigError("learner_options", str(error)) from None
            taken |= set(self._options_for(name, options))
        unused = sorted(set(options) - taken)
        if unused:
            raise ConfigError("learner_options", f"no learner of this run takes {unused} "
                                                 f"(learners: {', '.join(self.trained_learners())})")

    def trained_learners(self) -> tuple[str, ...]:
        """Every learner a cell of this run trains: main, sweep, literature (in that order)."""
        names = list(self.learners)
        if self.sweeps:
            names.append(self.sweep_learner)
        if self.literature:
            names.extend(LITERATURE_LEARNERS)
        return tuple(dict.fromkeys(names))

    def _options_for(self, name: str, options: dict) -> dict:
        """The subset of ``options`` the registered learner ``name`` takes; none for a learner that
        trains only literature cells (Cruz et al.'s methods keep their definitions)."""
        from tableclean_suite.learners import get_learner
        from tableclean_suite.learners.rules import ASSIST_OPTIONS, METHOD_OPTIONS

        if name not in self.learners and not (self.sweeps and name == self.sweep_learner):
            return {}
        accepted = METHOD_OPTIONS[get_learner(name).method] + ASSIST_OPTIONS
        return {key: value for key, value in options.items() if key in accepted}

    def learner(self, name: str):
        """The `TabularLearner` ``name`` with this run's ``learner_options``, ``q_init`` and ``exploration``."""
        from tableclean_suite.learners import get_learner
        from tableclean_suite.learners.exploration import parse_exploration

        options = self._options_for(name, parse_learner_options(self.learner_options))
        return get_learner(name).configured(options or None, self.q_init, parse_exploration(self.exploration))

    def task_spec(self):
        """The `TaskSpec` named by ``task`` (read from disk for a path)."""
        from tableclean_suite.task import get_task_spec

        try:
            return get_task_spec(self.task)
        except ValueError as error:
            raise ConfigError("task", str(error)) from None

    def task_model(self):
        """The `TaskModel` of ``task``, ``start`` and ``ineffective`` (None keeps the spec's)."""
        from tableclean_suite.task import TaskModel

        return TaskModel(spec=self.task_spec(), start=self.start, ineffective=self.ineffective)

    def transition_table(self, model):
        """The calibrated [`TransitionTable`][tableclean_suite.learners.transitions.TransitionTable] in file
        ``transitions``, for ``model``; None unless ``backend`` is calibrated."""
        from tableclean_suite.learners import TransitionTable

        return TransitionTable.from_json(self.transitions, model) if self.backend == "calibrated" else None

    def cell_settings(self) -> dict:
        """The fields that can change a cell's numbers (every field not in `NOT_IN_CELL_KEY`)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name not in self.NOT_IN_CELL_KEY}

    def to_json(self) -> dict:
        """All fields, JSON-serialisable (tuples as lists)."""
        return {name: list(value) if isinstance(value, tuple) else value for name, value in asdict(self).items()}


def parse_learner_options(text: str | None) -> dict:
    """``'{"planning_steps": 20}'`` or ``"planning_steps=20,lambda_=0.8"`` -> a dict (``{}`` for None/"").

    ``key=value`` values are read as JSON where they parse (numbers, true/false), else as text
    (``trace=accumulating``).  ``ConfigError`` on anything else.
    """
    if text is None or not str(text).strip():
        return {}
    text = str(text).strip()
    if text.startswith("{"):
        try:
            options = json.loads(text, object_pairs_hook=unique_keys)
        except json.JSONDecodeError as error:
            raise ConfigError("learner_options", f"learner_options is not valid JSON ({error}): {text!r}") from None
        except ValueError as error:  # a key given twice
            raise ConfigError("learner_options", f"learner_options: {error}: {text!r}") from None
        if not isinstance(options, dict):
            raise ConfigError("learner_options", f"learner_options must be a JSON object, got {text!r}")
        return options
    options = {}
    for item in filter(None, (part.strip() for part in text.split(","))):
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ConfigError("learner_options", f"learner_options item {item!r} must be key=value")
        if key.strip() in options:
            raise ConfigError("learner_options", f"learner_options key {key.strip()!r} is given twice")
        try:
            options[key.strip()] = json.loads(value.strip())
        except json.JSONDecodeError:
            options[key.strip()] = value.strip()
    return options


def _number(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(name, f"{value!r} is not a number")
    return float(value)


def _check_integer(name: str, value, low: int, high: int | None = None) -> None:
    if isinstance(value, bool) or not isinstance(value, int) or value < low or (high is not None and value > high):
        allowed = f"in [{low}, {high}]" if high is not None else f">= {low}"
        raise ConfigError(name, f"{name} must be an integer {allowed}, got {value!r}")


def _check_names(name: str, value, allowed) -> None:
    names = value if isinstance(value, (tuple, list)) else (value,)
    unknown = [n for n in names if n not in allowed]
    if unknown:
        raise ConfigError(name, f"unknown {', '.join(map(repr, unknown))}; allowed: {', '.join(allowed)}")


def _call(validate, field: str | None = None, **values) -> None:
    """Run a ``validate_hyperparameters``-style check; its ValueError names the argument."""
    try:
        validate(**values)
    except ValueError as error:
        named = str(error).split(" ", 1)[0]
        raise ConfigError(field or named, str(error)) from None


def field_docs() -> dict[str, str]:
    """``{field: docstring}`` of `RunConfig` (the string literal after each field), read from its
    source; empty when the source is not available (e.g. bytecode only)."""
    try:
        body = ast.parse(inspect.getsource(RunConfig)).body[0].body
    except (OSError, TypeError):
        return {}
    return {node.target.id: " ".join(following.value.value.split()) for node, following in zip(body, body[1:])
            if isinstance(node, ast.AnnAssign) and isinstance(following, ast.Expr)
            and isinstance(following.value, ast.Constant) and isinstance(following.value.value, str)}


def defaults() -> dict:
    """``{field: default}`` of `RunConfig` (the paper's settings)."""
    return {f.name: f.default for f in fields(RunConfig)}
