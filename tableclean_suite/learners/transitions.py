"""Transition tables that the compiled learners step: deterministic (the task model) or
empirical (measured from physics by ``benchmarks.calibrate``).

A table stores, for every (state, action) of its task, up to K successors with
cumulative probabilities; the model's table has K = 1.  Tables round-trip through JSON
(format ``tableclean_suite.transition_table``):

    {"format": "tableclean_suite.transition_table", "version": 2, "source": "...",
     "task": {...the TaskSpec as JSON...},
     "pairs": [{"state": 4, "action": "move", "executions": 100,
                "successors": [{"next_state": 5, "outcome": "routine", "probability": 1.0}]}, ...]}

Version 1 files (no ``"task"``) are read as the ``paper`` spec.  Reading validates every
entry against the task: integer state codes of non-terminal states, the spec's action
names, each pair at most once, probabilities summing to 1, and outcomes that agree with
their successor (TERMINAL exactly when the successor is terminal; ineffective,
irrelevant and improper outcomes leave the state unchanged).  Pairs the file does not
list take the task model's deterministic successor; how many did is reported in
`TransitionTable.model_filled_pairs` and `TransitionTable.source`.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tableclean_suite.atomic_files import atomic_write_text
from tableclean_suite.learners.kernel import sample_index
from tableclean_suite.task import NO_CHANGE_OUTCOMES, Outcome, TaskModel, TaskSpec, as_task_model, unique_keys

FORMAT_NAME = "tableclean_suite.transition_table"
FORMAT_VERSION = 2
#: Versions [`TransitionTable.from_json`][tableclean_suite.learners.transitions.TransitionTable.from_json] reads (1: the paper's task, no ``"task"`` field).
READABLE_VERSIONS = (1, 2)
_PROBABILITY_TOLERANCE = 1e-6


class CorruptTableError(ValueError):
    """A transition-table file that cannot be used; the message names the file, entry and problem."""


@dataclass
class TransitionTable:
    """Successor distributions for every (state, action) pair of a task.

    Attributes:
        next_state: ``(S, A, K)`` int64 successor codes.
        outcome: ``(S, A, K)`` int64 [`Outcome`][tableclean_suite.task.state.Outcome] codes.
        cumulative: ``(S, A, K)`` float64 cumulative probabilities (last entry 1.0;
            padding entries repeat the last successor with cumulative 1.0).
        source: where it came from (``"model"`` or a description of the measurement).
        counts: ``(S, A)`` int64 executions behind each pair (0 where the model filled in).
        spec: the [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] the codes belong to (None: any task of this shape).
        model_filled_pairs: reachable non-terminal pairs a measured table did not list,
            which therefore take the model's successor (0 for the model's own table).
    """

    next_state: np.ndarray
    outcome: np.ndarray
    cumulative: np.ndarray
    source: str = "model"
    counts: np.ndarray | None = None
    spec: TaskSpec | None = None
    model_filled_pairs: int = 0

    def __post_init__(self):
        if self.counts is None:
            self.counts = np.zeros(self.next_state.shape[:2], dtype=np.int64)

    @property
    def max_successors(self) -> int:
        """K, the most successors any pair has."""
        return int(self.next_state.shape[2])

    @property
    def shape(self) -> tuple[int, int]:
        """``(S, A)``: states and actions."""
        return int(self.next_state.shape[0]), int(self.next_state.shape[1])

    def check_model(self, model: TaskModel) -> None:
        """``ValueError`` unless this table fits ``model``'s states, actions and spec."""
        if self.shape != (model.n_states, model.n_actions):
            raise ValueError(f"transition table {self.source!r} has {self.shape[0]} states x {self.shape[1]} actions; "
                             f"task {model.spec.name!r} has {model.n_states} x {model.n_actions}")
        if self.spec is not None and _shape_of(self.spec) != _shape_of(model.spec):
            raise ValueError(f"transition table {self.source!r} was measured on task {self.spec.name!r} "
                             f"({self.spec.segments} segments, objects {list(self.spec.objects)}, actions "
                             f"{list(self.spec.actions)}), not on {model.spec.name!r}")

    @classmethod
    def from_model(cls, model: TaskModel) -> "TransitionTable":
        """The deterministic table of ``model`` (K = 1)."""
        next_state, outcome = model.transition_arrays()
        return cls(next_state[..., None], outcome[..., None], np.ones((*next_state.shape, 1)), "model",
                   spec=model.spec)

    @classmethod
    def from_counts(cls, counts: dict, fallback: TaskModel, source: str = "measured") -> "TransitionTable":
        """An empirical table from ``{(state, action): {(next_state, outcome): n}}``.

        Pairs never executed take ``fallback``'s deterministic successor.
        """
        distributions = {}
        executions = np.zeros((fallback.n_states, fallback.n_actions), dtype=np.int64)
        for (state, action), successors in counts.items():
            total = sum(successors.values())
            if total <= 0:
                continue
            executions[state, action] = total
            distributions[(state, action)] = [(s2, out, n / total) for (s2, out), n in sorted(successors.items())]
        return cls._from_distributions(distributions, fallback, source, executions)

    @classmethod
    def _from_distributions(cls, distributions, fallback: TaskModel, source, executions) -> "TransitionTable":
        model_next, model_outcome = fallback.transition_arrays()
        width = max([len(d) for d in distributions.values()] + [1])
        next_state = np.repeat(model_next[..., None], width, axis=2)
        outcome = np.repeat(model_outcome[..., None], width, axis=2)
        cumulative = np.ones((*model_next.shape, width))
        for (state, action), successors in distributions.items():
            running = 0.0
            for k, (s2, out, p) in enumerate(successors):
                running += p
                next_state[state, action, k] = s2
                outcome[state, action, k] = out
                cumulative[state, action, k] = running
            last = len(successors) - 1
            cumulative[state, action, last:] = 1.0
            next_state[state, action, last + 1 :] = next_state[state, action, last]
            outcome[state, action, last + 1 :] = outcome[state, action, last]
        filled = sum(
            1 for s in fallback.reachable_states() if not s.is_terminal
            for a in range(fallback.n_actions) if (s.index, a) not in distributions
        )
        if filled and distributions:
            source = f"{source} (+{filled} unmeasured reachable pairs from the task model)"
        return cls(next_state, outcome, cumulative, source, executions, fallback.spec, filled)

    def successors(self, state: int, action: int) -> list[tuple[int, int, float]]:
        """``[(next_state, outcome, probability), ...]`` of one pair."""
        probabilities = np.diff(self.cumulative[state, action], prepend=0.0)
        return [(int(nxt), int(out), float(p)) for nxt, out, p in
                zip(self.next_state[state, action], self.outcome[state, action], probabilities) if p > 0]

    def sample(self, state: int, action: int, draw: float) -> tuple[int, int]:
        """The successor picked by a uniform ``draw`` in [0, 1): ``(next_state, outcome)`` (as the compiled loop
        picks it, [`sample_index`][tableclean_suite.learners.kernel.sample_index])."""
        k = sample_index(self.cumulative[state, action], draw)
        return int(self.next_state[state, action, k]), int(self.outcome[state, action, k])

    # -- JSON ----------------------------------------------------------------------
    def to_json(self, path: str | Path, model: TaskModel | None = None) -> None:
        """Write the table as JSON (atomically), one entry per non-terminal pair, with counts.

        ``model`` (default: the table's spec) names the actions and the task.
        """
        model = model if model is not None else as_task_model(self.spec)
        self.check_model(model)
        pairs = []
        for state in range(model.n_states):
            if model.decode(state).is_terminal:
                continue
            for action in range(model.n_actions):
                pairs.append(
                    {
                        "state": state,
                        "action": model.action_names[action],
                        "executions": int(self.counts[state, action]),
                        "successors": [
                            {"next_state": s2, "outcome": Outcome(out).name.lower(), "probability": p}
                            for s2, out, p in self.successors(state, action)
                        ],
                    }
                )
        document = {"format": FORMAT_NAME, "version": FORMAT_VERSION, "source": self.source,
                    "task": model.spec.to_dict(), "pairs": pairs}
        atomic_write_text(path, json.dumps(document, indent=1))

    @classmethod
    def from_json(cls, path: str | Path, fallback: TaskModel | None = None) -> "TransitionTable":
        """Read a table written by [`to_json`][tableclean_suite.learners.transitions.TransitionTable.to_json]; [`CorruptTableError`][tableclean_suite.learners.transitions.CorruptTableError] names what is wrong.

        ``fallback`` is the task model the table must belong to (default: the file's own
        task, else ``paper``); unlisted pairs take its successors (reported, see the module
        docstring).
        """
        path = Path(path)
        try:
            document = json.loads(path.read_text(encoding="utf-8"), object_pairs_hook=unique_keys)
        except FileNotFoundError:
            raise
        except RecursionError:
            raise CorruptTableError(f"{path}: nested too deeply to be a transition table") from None
        except (OSError, ValueError) as error:
            raise CorruptTableError(f"{path}: not a JSON transition table ({error})") from None
        if not isinstance(document, dict) or document.get("format") != FORMAT_NAME:
            raise CorruptTableError(f"{path}: 'format' must be {FORMAT_NAME!r}")
        version = document.get("version")
        if version not in READABLE_VERSIONS:
            raise CorruptTableError(f"{path}: unsupported version {version!r}; readable: {list(READABLE_VERSIONS)}")
        try:
            spec = TaskSpec.from_dict(document["task"], f"{path}: task") if version >= 2 else as_task_model().spec
        except (KeyError, ValueError) as error:
            raise CorruptTableError(f"{path}: missing or invalid 'task' ({error})") from None
        model = fallback if fallback is not None else as_task_model(spec)
        if _shape_of(spec) != _shape_of(model.spec):
            raise CorruptTableError(f"{path}: measured on task {spec.name!r} ({spec.segments} segments, objects "
                                    f"{list(spec.objects)}, actions {list(spec.actions)}), not on {model.spec.name!r}")
        pairs = document.get("pairs")
        if not isinstance(pairs, list) or not pairs:
            raise CorruptTableError(f"{path}: 'pairs' must be a non-empty list of measured (state, action) pairs")
        distributions, executions = {}, np.zeros((model.n_states, model.n_actions), dtype=np.int64)
        for index, pair in enumerate(pairs):
            key, successors, count = _read_pair(pair, model, f"{path}: pairs[{index}]")
            if key in distributions:
                raise CorruptTableError(f"{path}: pairs[{index}]: (state {key[0]}, action "
                                        f"{model.action_names[key[1]]!r}) is listed more than once")
            distributions[key] = successors
            executions[key] = count
        return cls._from_distributions(distributions, model, document.get("source", str(path)), executions)

    def describe_pair(self, state: int, action: int, model: TaskModel | None = None) -> str:
        """One line, e.g. ``'S1:unclean+obj S2:unclean | arm@S1 pick -> 5 (routine) p=1.00'``."""
        model = model if model is not None else as_task_model(self.spec)
        parts = [
            f"{s2} ({Outcome(out).name.lower()}) p={p:.2f}" for s2, out, p in self.successors(state, action)
        ]
        return f"{model.decode(state).name} {model.action_names[action]} -> " + ", ".join(parts)


def _shape_of(spec: TaskSpec) -> tuple:
    """What a table's codes depend on: segments, object types and actions."""
    return spec.segments, spec.objects, spec.actions


def _json_int(value, what: str, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise CorruptTableError(f"{where}: {what} must be an integer, got {value!r}")
    return value


def _read_pair(pair, model: TaskModel, where: str) -> tuple[tuple[int, int], list, int]:
    """Validate one ``pairs`` entry: ``((state, action), [(next, outcome, p), ...], executions)``."""
    if not isinstance(pair, dict) or not {"state", "action", "successors"} <= set(pair):
        raise CorruptTableError(f"{where}: an entry needs 'state', 'action' and 'successors', got {pair!r}")
    state = _json_int(pair["state"], "state", where)
    if not 0 <= state < model.n_states:
        raise CorruptTableError(f"{where}: state {state} outside [0, {model.n_states})")
    if model.decode(state).is_terminal:
        raise CorruptTableError(f"{where}: state {state} is terminal; a table lists only non-terminal states")
    try:
        action = model.action_index(str(pair["action"]))
    except ValueError as error:
        raise CorruptTableError(f"{where}: {error}") from None
    count = _json_int(pair.get("executions", 0), "executions", where)
    if count < 0:
        raise CorruptTableError(f"{where}: executions must be >= 0, got {count}")
    if not isinstance(pair["successors"], list) or not pair["successors"]:
        raise CorruptTableError(f"{where}: 'successors' must be a non-empty list")
    successors = []
    for k, entry in enumerate(pair["successors"]):
        at = f"{where}.successors[{k}]"
        if not isinstance(entry, dict):
            raise CorruptTableError(f"{at}: expected an object, got {entry!r}")
        nxt = _json_int(entry.get("next_state"), "next_state", at)
        if not 0 <= nxt < model.n_states:
            raise CorruptTableError(f"{at}: next_state {nxt} outside [0, {model.n_states})")
        name = str(entry.get("outcome", "")).upper()
        if name not in Outcome.__members__:
            allowed = ", ".join(o.name.lower() for o in Outcome)
            raise CorruptTableError(f"{at}: unknown outcome {entry.get('outcome')!r}; allowed: {allowed}")
        outcome = Outcome[name]
        probability = entry.get("probability")
        if isinstance(probability, bool) or not isinstance(probability, (int, float)) or not 0.0 <= probability <= 1.0:
            raise CorruptTableError(f"{at}: probability must be a number in [0, 1], got {probability!r}")
        terminal = model.decode(nxt).is_terminal
        if terminal != (outcome == Outcome.TERMINAL):
            raise CorruptTableError(f"{at}: outcome {outcome.name.lower()} with next_state {nxt} "
                                    f"({'terminal' if terminal else 'not terminal'}); TERMINAL must go with, and "
                                    f"only with, a terminal successor")
        if outcome in NO_CHANGE_OUTCOMES and nxt != state:
            raise CorruptTableError(f"{at}: outcome {outcome.name.lower()} leaves the state unchanged, but "
                                    f"next_state {nxt} != state {state}")
        successors.append((nxt, int(outcome), float(probability)))
    total = sum(p for _, _, p in successors)
    if abs(total - 1.0) > _PROBABILITY_TOLERANCE:
        raise CorruptTableError(f"{where}: probabilities sum to {total}, not 1")
    return (state, action), successors, count
