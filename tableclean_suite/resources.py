"""The resource guard: estimate what a task spec and a budget need before allocating, refuse what
cannot fit.

Estimates are sized by the spec (S state codes, A actions) and the budget (R runs, T iterations):
the transition tables, the Q-tables ([`q_table_copies`][tableclean_suite.resources.q_table_copies]),
each run's working arrays, the records and the training time
([`training_seconds`][tableclean_suite.resources.training_seconds]).  The ``require_*`` functions
raise a [`ResourceError`][tableclean_suite.resources.ResourceError] whose one-line message names the
estimate, what is allowed or available, and the override: the environment variable `OVERRIDE_ENV`
set to ``1`` (executor workers inherit it).
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, field

#: Environment variable that, set to one of `TRUE_WORDS`, turns the guard's refusals off.
OVERRIDE_ENV = "TABLECLEAN_IGNORE_RESOURCE_CHECK"
#: Values of `OVERRIDE_ENV` that mean "on" (case-insensitive).
TRUE_WORDS = ("1", "true", "yes", "on")
#: Fraction of the available memory (bytes) that an estimate may take; the rest is headroom for
#: the interpreter, libraries and what the estimate leaves out.
USABLE_FRACTION = 0.8
#: Bytes of a float64 or an int64.
WORD_BYTES = 8
#: Bytes per (state, action) pair of the model's table and the learners' (next states and outcomes,
#: their copies, cumulative probabilities, execution counts).
TABLE_BYTES_PER_PAIR = 6 * WORD_BYTES
#: Bytes per state code of the vectorised rule build ([`batch_rules`][tableclean_suite.task.batch_rules]).
BUILD_BYTES_PER_STATE = 8 * WORD_BYTES
#: Integer record arrays per (run, iteration): outcome, state, action, episode end (each of the
#: task's record dtype, ``TaskModel.record_dtype``); a float64 reward comes with them.
RECORD_CODE_ARRAYS = 4
#: Learner steps per second assumed by time estimates, compiled and plain-Python reference loops (a
#: fast machine's, so the estimates err towards allowing).
STEPS_PER_SECOND = 50_000_000
REFERENCE_STEPS_PER_SECOND = 300_000
#: Engine name -> learner steps per second assumed by time estimates.
ENGINE_STEPS_PER_SECOND = {"compiled": STEPS_PER_SECOND, "reference": REFERENCE_STEPS_PER_SECOND}
#: Q-table entries per second a run's setup writes before its first step (a fast machine's).
TABLE_ENTRIES_PER_SECOND = 200_000_000
#: The engine ``train()`` uses unless told otherwise (the benchmark grid and ``tune`` never choose another).
DEFAULT_ENGINE = "compiled"
#: Bytes per Q entry in the reference loop's Python tables (list slot, float object, row share).
PYTHON_ENTRY_BYTES = 6 * WORD_BYTES
#: Bytes per (state, action) pair of one run's working memory in the compiled loop: eligibility
#: traces, Dyna's model, learned affordances.
TRACE_BYTES_PER_PAIR = 2 * WORD_BYTES
DYNA_BYTES_PER_PAIR = 3 * WORD_BYTES + 1
LEARNED_AFFORDANCE_BYTES_PER_PAIR = 1
#: Longest estimated training (and analysis) a command may need before it is refused: seconds (1 day).
MAX_TRAINING_SECONDS = 24 * 3600
#: Calls of user actions' Python effects a table build may make (about 8.5 us each).
MAX_USER_EFFECT_CALLS = 500_000

_UNITS = ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB")
_UNIT_STEP = 1024


class ResourceError(ValueError):
    """A request refused before work (commands: one line, exit 2); the guard's name the estimate and the override."""


class InsufficientMemoryError(ResourceError):
    """An allocation estimated to need more memory than is available."""


class TooMuchWorkError(ResourceError):
    """A build or a training estimated to run for longer than the guard allows."""


def format_bytes(n: float) -> str:
    """``1536`` -> ``'1.5 KiB'`` (binary units)."""
    value = float(n)
    for unit in _UNITS:
        if abs(value) < _UNIT_STEP or unit == _UNITS[-1]:
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= _UNIT_STEP
    raise AssertionError("unreachable")  # pragma: no cover


def format_seconds(seconds: float) -> str:
    """``90000`` -> ``'1.0 days'``, ``0.25`` -> ``'0.25 s'``; seconds (two significant digits below
    10), hours or days."""
    if seconds < 10:
        return f"{seconds:.2g} s"
    if seconds < 3600:
        return f"{seconds:.0f} s"
    if seconds < 24 * 3600:
        return f"{seconds / 3600:.1f} hours"
    return f"{seconds / (24 * 3600):.1f} days"


@dataclass(frozen=True)
class MemoryEstimate:
    """Bytes an allocation needs, by part (e.g. ``{"Q-tables": ..., "records": ...}``)."""

    parts: dict = field(default_factory=dict)

    @property
    def total(self) -> int:
        """Sum of the parts, bytes."""
        return int(sum(self.parts.values()))

    def __add__(self, other: "MemoryEstimate") -> "MemoryEstimate":
        merged = dict(self.parts)
        for name, size in other.parts.items():
            merged[name] = merged.get(name, 0) + size
        return MemoryEstimate(merged)

    def describe(self) -> str:
        """``'3.1 GiB (Q-tables 2.0 GiB, records 1.1 GiB)'`` (parts above zero, largest first)."""
        parts = sorted(((size, name) for name, size in self.parts.items() if size > 0), reverse=True)
        inner = ", ".join(f"{name} {format_bytes(size)}" for size, name in parts)
        return f"{format_bytes(self.total)} ({inner})" if inner else format_bytes(self.total)


def override_enabled() -> bool:
    """Whether `OVERRIDE_ENV` turns the guard off."""
    return os.environ.get(OVERRIDE_ENV, "").strip().lower() in TRUE_WORDS


def available_bytes() -> int:
    """Memory the operating system can give this process now without swapping (psutil), bytes."""
    import psutil

    return int(psutil.virtual_memory().available)


def table_memory(n_states: int, n_actions: int, max_successors: int = 1) -> MemoryEstimate:
    """Building a task model's table and the table learners step (S states, A actions, K successors)."""
    pairs = int(n_states) * int(n_actions)
    return MemoryEstimate({"transition tables": pairs * TABLE_BYTES_PER_PAIR * max(1, int(max_successors)),
                           "rule build": int(n_states) * BUILD_BYTES_PER_STATE})


def q_table_copies(q_tables: int = 1, checkpoint: bool = False) -> int:
    """(S x A) float64 tables per run a compiled ``train()`` holds at its peak.

    One learner table (``q_tables=1``): the table, and its snapshot with a ``checkpoint``.  Two
    (double Q-learning): tables A and B, the result's average of both and their ``(2, S, A)``
    stack (5), and with a ``checkpoint`` the snapshots of A and B and their average (3 more).
    """
    tables = max(1, int(q_tables))
    copies = tables if tables == 1 else 2 * tables + 1
    if checkpoint:
        copies += tables if tables == 1 else tables + 1
    return copies


def training_memory(n_states: int, n_actions: int, runs: int, iterations: int, q_tables: int = 1,
                    max_successors: int = 1, code_bytes: int = 4, checkpoint: bool = False,
                    engine: str = DEFAULT_ENGINE, run_bytes: int = 0, concurrent_runs: int = 1) -> MemoryEstimate:
    """One ``train()`` call on a table backend, bytes by part.

    Args:
        n_states, n_actions: the task's S state codes and A actions.
        runs, iterations: the budget, R runs x T iterations.
        q_tables: learner tables per run (2 for double Q-learning); the copies held at the peak are
            [`q_table_copies`][tableclean_suite.resources.q_table_copies].
        max_successors: K successors per (state, action) pair of the stepped table.
        code_bytes: bytes of a record code (``TaskModel.record_dtype.itemsize``).
        checkpoint: the call keeps the Q-tables after ``checkpoint`` iterations (snapshots).
        engine: ``"compiled"``, or ``"reference"``, whose per-run arrays are stacked into the
            result (records and Q-tables twice) and whose learner tables are Python lists
            (`PYTHON_ENTRY_BYTES` per entry, one run at a time).
        run_bytes: one run's working arrays in the compiled loop
            ([`tableclean_suite.learners.memory.run_working_bytes`][tableclean_suite.learners.memory.run_working_bytes]).
        concurrent_runs: runs the compiled loop trains at once (its threads, at most ``runs``).
    """
    pairs = int(n_states) * int(n_actions)
    tables = max(1, int(q_tables))
    copies = q_table_copies(tables, checkpoint)
    records = int(runs) * int(iterations) * (WORD_BYTES + RECORD_CODE_ARRAYS * int(code_bytes))
    if engine == "reference":
        stacked = 2  # each run's arrays, then the result's stack of them
        parts = {"Q-tables": stacked * int(runs) * pairs * WORD_BYTES * (1 + (tables if tables > 1 else 0)
                                                                         + int(bool(checkpoint))),
                 "records": stacked * records,
                 "run working memory": pairs * (tables * PYTHON_ENTRY_BYTES + (2 * tables + 1) * WORD_BYTES)}
    else:
        parts = {"Q-tables": int(runs) * pairs * WORD_BYTES * copies, "records": records,
                 "run working memory": int(run_bytes) * max(1, min(int(runs), int(concurrent_runs)))}
    return table_memory(n_states, n_actions, max_successors) + MemoryEstimate(parts)


def steps_per_second(engine: str) -> float:
    """Learner steps per second assumed for ``engine`` (`ENGINE_STEPS_PER_SECOND`); ``ValueError``
    names the engines allowed."""
    if engine not in ENGINE_STEPS_PER_SECOND:
        raise ValueError(f"unknown engine {engine!r}; allowed: {', '.join(ENGINE_STEPS_PER_SECOND)}")
    return float(ENGINE_STEPS_PER_SECOND[engine])


def training_seconds(runs: int, iterations: int, n_states: int, n_actions: int, engine: str = DEFAULT_ENGINE,
                     planning_steps: int = 0, q_tables: int = 1) -> float:
    """Estimated seconds of training ``runs`` runs of ``iterations`` iterations (the compiled or the
    reference ``engine``), every update a learner makes counted.

    Args:
        runs, iterations: the budget, R runs x T iterations.
        n_states, n_actions: the task's S state codes and A actions.
        engine: ``"compiled"`` or ``"reference"`` ([`steps_per_second`][tableclean_suite.resources.steps_per_second]).
        planning_steps: Dyna-Q's planning updates per real step (each costs about a step), >= 0.
        q_tables: learner tables per run (2 for double Q-learning).

    Returns:
        ``R x T x (1 + planning_steps)`` updates at the engine's rate, plus each run's setup: its
        ``q_tables x S x A`` entries at `TABLE_ENTRIES_PER_SECOND`.
    """
    updates = int(runs) * int(iterations) * (1 + max(0, int(planning_steps)))
    setup = int(runs) * max(1, int(q_tables)) * int(n_states) * int(n_actions) / TABLE_ENTRIES_PER_SECOND
    return updates / steps_per_second(engine) + setup


def require_training_time(runs: int, iterations: int, n_states: int, n_actions: int, what: str,
                          engine: str = DEFAULT_ENGINE, planning_steps: int = 0, q_tables: int = 1,
                          extra_seconds: float = 0.0, extra_detail: str = "") -> float:
    """[`require_time`][tableclean_suite.resources.require_time] of [`training_seconds`][tableclean_suite.resources.training_seconds] (plus ``extra_seconds``, e.g. the analysis's,
    described by ``extra_detail``); returns the estimate in seconds.  The refusal names every
    part: updates (Dyna-Q's planning updates included), the runs' setup and the extra."""
    seconds = training_seconds(runs, iterations, n_states, n_actions, engine, planning_steps, q_tables)
    updates = int(runs) * int(iterations) * (1 + max(0, int(planning_steps)))
    planning = f" ({int(planning_steps)} planning updates per step)" if planning_steps else ""
    entries = max(1, int(q_tables)) * int(n_states) * int(n_actions)
    detail = (f"{updates:.3g} learner updates{planning} at {steps_per_second(engine):.3g}/s ({engine} engine) and "
              f"{int(runs)} runs' setup of {entries:.3g} table entries at {TABLE_ENTRIES_PER_SECOND:.3g}/s")
    require_time(seconds + float(extra_seconds), what, f"{detail}{'; ' + extra_detail if extra_detail else ''}")
    return seconds + float(extra_seconds)


def bounded_product(terms, limit: int) -> int | None:
    """``prod(base ** exponent for base, exponent in terms)`` (``(base, exponent)`` pairs of
    non-negative integers) when it is at most ``limit`` (an integer >= 1), else None; decided on
    logarithms first, so ``2 ** (10 ** 30)`` costs no arithmetic."""
    total_bits = 0.0
    exact = []
    for base, exponent in terms:
        base, exponent = int(base), int(exponent)
        if base < 0 or exponent < 0:
            raise ValueError(f"bounded_product takes non-negative bases and exponents, got {base}**{exponent}")
        if base == 0 and exponent > 0:
            return 0
        if base <= 1 or exponent == 0:
            continue
        if exponent.bit_length() > 64:  # at least 2**(2**64): far past any limit
            return None
        total_bits += exponent * math.log2(base)
        if total_bits > math.log2(int(limit)) + 1:
            return None
        exact.append((base, exponent))
    product = math.prod(base**exponent for base, exponent in exact)
    return product if product <= int(limit) else None


def _refuse(error: type, message: str) -> None:
    """Raise ``error`` with ``message`` and the override's hint, unless `OVERRIDE_ENV` is set."""
    if not override_enabled():
        raise error(f"{message}, or set {OVERRIDE_ENV}=1 to try anyway")


def require_memory(estimate: MemoryEstimate, what: str, available: int | None = None) -> None:
    """Raise [`InsufficientMemoryError`][tableclean_suite.resources.InsufficientMemoryError] when ``estimate`` exceeds `USABLE_FRACTION` of
    the available memory (``available``: bytes, default [`available_bytes`][tableclean_suite.resources.available_bytes]).

    Args:
        estimate: what the allocation needs.
        what: what is being allocated, for the message (e.g. ``"training 'q_learning' on task 'big'"``).
    """
    if override_enabled():
        return
    available = available_bytes() if available is None else int(available)
    if estimate.total > USABLE_FRACTION * available:
        _refuse(InsufficientMemoryError, f"{what} needs about {estimate.describe()}, but only "
                f"{format_bytes(available)} of memory is available (at most {USABLE_FRACTION:.0%} of it may be "
                "used); use a smaller task or budget")


def require_time(seconds: float, what: str, detail: str = "") -> None:
    """Raise [`TooMuchWorkError`][tableclean_suite.resources.TooMuchWorkError] when an estimate of ``seconds`` exceeds `MAX_TRAINING_SECONDS`.

    Args:
        seconds: the estimated wall time.
        what: what would take that long, for the message.
        detail: how the estimate was made (e.g. ``"1e15 learner steps at 5e7 steps/s"``).
    """
    if seconds > MAX_TRAINING_SECONDS:
        how = f" ({detail})" if detail else ""
        _refuse(TooMuchWorkError, f"{what} would take about {format_seconds(seconds)}{how}, more than the "
                f"{format_seconds(MAX_TRAINING_SECONDS)} allowed; use fewer runs, iterations or a smaller task")


#: Longest estimated time of a table build's user action effects, timed on its first states (seconds).
MAX_EFFECT_SECONDS = 60
#: Above this estimate (seconds) a table build says on stderr how long its user action effects take.
NOTICE_EFFECT_SECONDS = 5


def require_effect_seconds(seconds: float, what: str) -> None:
    """Raise [`TooMuchWorkError`][tableclean_suite.resources.TooMuchWorkError] when a table build's user
    action effects, timed on its first states, would take more than `MAX_EFFECT_SECONDS` in all;
    above `NOTICE_EFFECT_SECONDS` say the estimate on stderr."""
    if seconds > MAX_EFFECT_SECONDS:
        _refuse(TooMuchWorkError, f"{what}: its user action effects, timed on its first states, would take about "
                f"{format_seconds(seconds)}, more than the {MAX_EFFECT_SECONDS} s allowed; use faster effects or a "
                "smaller task")
    if seconds > NOTICE_EFFECT_SECONDS:
        print(f"{what}: user action effects take about {format_seconds(seconds)}", file=sys.stderr, flush=True)


def require_effect_calls(calls: int, what: str) -> None:
    """Raise [`TooMuchWorkError`][tableclean_suite.resources.TooMuchWorkError] when building a table would call user action effects more
    than `MAX_USER_EFFECT_CALLS` times (pure Python, about 8.5 us each)."""
    if int(calls) > MAX_USER_EFFECT_CALLS:
        _refuse(TooMuchWorkError, f"{what} calls user action effects {int(calls)} times (pure Python; at most "
                f"{MAX_USER_EFFECT_CALLS} are allowed, a few seconds); use fewer segments or objects")


#: Python rule steps (state x action, about 8.5 us each) a per-state walk of a task may take: the
#: reachable-state search, plan lengths and listings (about 17 s); larger specs are refused.
MAX_PYTHON_RULE_STEPS = 2_000_000


def require_python_steps(steps: int, what: str) -> None:
    """Raise [`TooMuchWorkError`][tableclean_suite.resources.TooMuchWorkError] when a pure-Python walk over a task's states would step its
    rules more than `MAX_PYTHON_RULE_STEPS` times."""
    if int(steps) > MAX_PYTHON_RULE_STEPS:
        _refuse(TooMuchWorkError, f"{what} steps the task's rules state by state up to {int(steps)} times (pure "
                f"Python, about {format_seconds(int(steps) * 8.5e-6)}; at most {MAX_PYTHON_RULE_STEPS} are allowed); "
                "use fewer segments or objects")
