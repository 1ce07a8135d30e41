"""One source of truth for a benchmark run's configuration: :class:`RunConfig`.

Every default of ``python -m tableclean_suite.bench.run`` is written here once.  The command line
(:mod:`.run`) takes its defaults and help texts from this class, ``train()`` takes its arguments
from it (:meth:`RunConfig.train_kwargs`), ``config.json`` records it (:meth:`RunConfig.to_json`)
and a cell's cache key includes every field that can change a number
(:meth:`RunConfig.cell_settings`).

    from tableclean_suite.bench.config import RunConfig
    config = RunConfig(runs=200, rewards=("r2", "r4"), sweeps=False)
"""

from __future__ import annotations

import ast
import inspect
import math
from dataclasses import asdict, dataclass, fields
from typing import ClassVar

from tableclean_suite.bench.statistics import DEFAULT_CONFIDENCE, DEFAULT_SAMPLES
from tableclean_suite.metrics import DEFAULT_PLATEAU_FRACTION, DEFAULT_THRESHOLD

#: Fraction of the runs that must have finished an episode for an average-reward point to count.
DEFAULT_SUPPORT_FRACTION = 0.5
#: Largest ``bootstrap_samples``.
MAX_BOOTSTRAP_SAMPLES = 100_000

#: Episode start modes and ineffective-action modes a task spec can be overridden with.
START_MODES = ("fixed", "uniform_unclean")
INEFFECTIVE_MODES = ("ineffective", "improper")


class ConfigError(ValueError):
    """A field with a value it cannot take.

    Attributes:
        field: the :class:`RunConfig` field.
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
    """Epsilon-greedy exploration rate, in [0, 1]."""
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
    support_fraction: float = DEFAULT_SUPPORT_FRACTION
    """Fraction of the runs that must have finished an episode before an average-reward point counts, in [0, 1]."""
    bootstrap_samples: int = DEFAULT_SAMPLES
    """Bootstrap replicates behind each interval and band, an integer in [1, 100000]."""
    confidence: float = DEFAULT_CONFIDENCE
    """Coverage of the intervals, in (0, 1)."""
    backend: str = "symbolic"
    """Training backend: symbolic model, calibrated transition table, or skills in MuJoCo physics."""
    transitions: str | None = None
    """Transition table JSON (from python -m benchmarks.calibrate); only with --backend calibrated."""
    workers: int | None = None
    """Processes (physics backend) or compiled threads (other backends), >= 1; default: all cores."""
    out: str = "results"
    """Output directory (created if missing)."""
    figures: bool = True
    """Draw the PNG figures."""
    fresh: bool = False
    """Retrain every cell, ignoring (and overwriting) the saved ones."""
    progress: bool = True
    """Show a progress bar over cells on stderr."""
    verbose: bool = False
    """Show the warnings robosuite logs when it is imported (physics backend)."""

    #: Fields that never change a cell's numbers as such: a cell's own learner, reward, alpha and
    #: gamma enter its key as the cell; the task and the transition table enter by content
    #: (the model's code digest, the table file's SHA-256), not by name or path.
    NOT_IN_CELL_KEY: ClassVar[tuple[str, ...]] = (
        "learners", "rewards", "alpha", "gamma", "alpha_sweep", "gamma_sweep", "sweep_learner", "sweep_reward",
        "sweeps", "task", "transitions", "workers", "out", "figures", "fresh", "progress", "verbose",
    )
    #: Name lists de-duplicated in order; value lists too (compared as floats).
    _LISTS: ClassVar[tuple[str, ...]] = ("learners", "rewards", "alpha_sweep", "gamma_sweep")

    def __post_init__(self):
        for name in self._LISTS:
            value = getattr(self, name)
            items = (value,) if isinstance(value, (str, int, float)) else tuple(value)
            if name.endswith("_sweep"):
                items = tuple(_number(name, v) for v in items)
            object.__setattr__(self, name, tuple(dict.fromkeys(items)))
            if not getattr(self, name):
                raise ConfigError(name, "give at least one value")
        self._validate()

    def _validate(self) -> None:
        from tableclean_suite.learners import learner_names, validate_hyperparameters
        from tableclean_suite.rewards import reward_pattern_names

        learners, rewards = learner_names(), reward_pattern_names()
        for name in ("learners", "sweep_learner"):
            _check_names(name, getattr(self, name), learners)
        for name in ("rewards", "sweep_reward"):
            _check_names(name, getattr(self, name), rewards)
        hyper = dict(runs=self.runs, iterations=self.iterations, alpha=self.alpha, gamma=self.gamma,
                     epsilon=self.epsilon, max_itr=self.max_itr, seed=self.seed)
        _call(validate_hyperparameters, **hyper)
        for name, key in (("alpha_sweep", "alpha"), ("gamma_sweep", "gamma")):
            for value in getattr(self, name):
                _call(validate_hyperparameters, field=name, **{**hyper, key: value})
        for name in ("threshold", "plateau_fraction"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and 0.0 < value <= 1.0):
                raise ConfigError(name, f"{name} must be in (0, 1], got {value!r}")
        if not (isinstance(self.support_fraction, (int, float)) and 0.0 <= self.support_fraction <= 1.0):
            raise ConfigError("support_fraction", f"support_fraction must be in [0, 1], got {self.support_fraction!r}")
        if not (isinstance(self.confidence, (int, float)) and 0.0 < self.confidence < 1.0):
            raise ConfigError("confidence", f"confidence must be in (0, 1), got {self.confidence!r}")
        if (isinstance(self.bootstrap_samples, bool) or not isinstance(self.bootstrap_samples, int)
                or not 1 <= self.bootstrap_samples <= MAX_BOOTSTRAP_SAMPLES):
            raise ConfigError("bootstrap_samples", "bootstrap_samples must be an integer in "
                              f"[1, {MAX_BOOTSTRAP_SAMPLES}], got {self.bootstrap_samples!r}")
        self.task_spec()
        for name, allowed in (("start", START_MODES), ("ineffective", INEFFECTIVE_MODES)):
            value = getattr(self, name)
            if value is not None and value not in allowed:
                raise ConfigError(name, f"unknown {value!r}; allowed: {', '.join(allowed)}")
        if self.workers is not None and (isinstance(self.workers, bool) or not isinstance(self.workers, int)
                                         or self.workers < 1):
            raise ConfigError("workers", f"workers must be an integer >= 1, got {self.workers!r}")
        backends = backend_names()
        if self.backend not in backends:
            raise ConfigError("backend", f"unknown {self.backend!r}; allowed: {', '.join(backends)}")
        if self.backend == "calibrated" and self.transitions is None:
            raise ConfigError("transitions", "needed by backend calibrated (a table from benchmarks.calibrate)")
        if self.backend != "calibrated" and self.transitions is not None:
            raise ConfigError("transitions", "only used with backend calibrated")

    def task_spec(self):
        """The :class:`~tableclean_suite.task.TaskSpec` named by ``task`` (read from disk for a path)."""
        from tableclean_suite.task import get_task_spec

        try:
            return get_task_spec(self.task)
        except ValueError as error:
            raise ConfigError("task", str(error)) from None

    def task_model(self):
        """The :class:`~tableclean_suite.task.TaskModel` of ``task``, ``start`` and ``ineffective``
        (None keeps the spec's)."""
        from tableclean_suite.task import TaskModel

        return TaskModel(spec=self.task_spec(), start=self.start, ineffective=self.ineffective)

    def train_kwargs(self) -> dict:
        """The keyword arguments of ``train()`` shared by every cell (not learner, reward, alpha,
        gamma, runs, first_run, model or transitions, which the harness supplies per cell/chunk)."""
        return dict(iterations=self.iterations, epsilon=self.epsilon, max_itr=self.max_itr, seed=self.seed,
                    backend=self.backend, workers=self.workers)

    def cell_settings(self) -> dict:
        """The fields that can change a cell's numbers (every field not in :data:`NOT_IN_CELL_KEY`)."""
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name not in self.NOT_IN_CELL_KEY}

    def to_json(self) -> dict:
        """All fields, JSON-serialisable (tuples as lists)."""
        return {name: list(value) if isinstance(value, tuple) else value for name, value in asdict(self).items()}


def backend_names() -> list[str]:
    """The training backends ``train()`` accepts (built-in and registered)."""
    from tableclean_suite.learners import available_backends

    return list(available_backends())


def _number(name: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(name, f"{value!r} is not a number")
    return float(value)


def _check_names(name: str, value, allowed: list[str]) -> None:
    names = (value,) if isinstance(value, str) else value
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


def field_docs(cls=RunConfig) -> dict[str, str]:
    """``{field: docstring}`` of a dataclass written with a string literal after each field.

    Read from the class's source; empty when the source is not available (e.g. bytecode only).
    """
    try:
        tree = ast.parse(inspect.getsource(cls))
    except (OSError, TypeError):
        return {}
    body = tree.body[0].body
    docs = {}
    for node, following in zip(body, body[1:]):
        if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                and isinstance(following, ast.Expr) and isinstance(following.value, ast.Constant)
                and isinstance(following.value.value, str)):
            docs[node.target.id] = " ".join(following.value.value.split())
    return docs


def defaults() -> dict:
    """``{field: default}`` of :class:`RunConfig` (the paper's settings)."""
    return {f.name: f.default for f in fields(RunConfig)}
