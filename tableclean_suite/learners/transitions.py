"""Transition tables that the compiled learners step: deterministic (the task model) or
empirical (measured from physics by ``benchmarks.calibrate``).

A table stores, for every (state, action), up to K successors with cumulative
probabilities; the model's table has K = 1.  Tables round-trip through JSON.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tableclean_suite.task import N_ACTIONS, N_STATES, Action, Outcome, TaskModel, decode

FORMAT_NAME = "tableclean_suite.transition_table"
FORMAT_VERSION = 1
_PROBABILITY_TOLERANCE = 1e-6


class CorruptTableError(ValueError):
    """A transition-table file that cannot be read; the message names the problem."""


@dataclass
class TransitionTable:
    """Successor distributions for all 24 x 4 (state, action) pairs.

    Attributes:
        next_state: ``(24, 4, K)`` int64 successor codes.
        outcome: ``(24, 4, K)`` int64 :class:`Outcome` codes.
        cumulative: ``(24, 4, K)`` float64 cumulative probabilities (last entry 1.0;
            padding entries repeat the last successor with cumulative 1.0).
        source: where it came from (``"model"`` or a description of the measurement).
        counts: ``(24, 4)`` int64 executions behind each pair (0 where the model filled in).
    """

    next_state: np.ndarray
    outcome: np.ndarray
    cumulative: np.ndarray
    source: str = "model"
    counts: np.ndarray = field(default_factory=lambda: np.zeros((N_STATES, N_ACTIONS), dtype=np.int64))

    @property
    def max_successors(self) -> int:
        """K, the most successors any pair has."""
        return int(self.next_state.shape[2])

    @classmethod
    def from_model(cls, model: TaskModel) -> "TransitionTable":
        """The deterministic table of ``model`` (K = 1)."""
        next_state, outcome = model.transition_arrays()
        return cls(next_state[..., None], outcome[..., None], np.ones((N_STATES, N_ACTIONS, 1)), "model")

    @classmethod
    def from_counts(cls, counts: dict, fallback: TaskModel, source: str = "measured") -> "TransitionTable":
        """An empirical table from ``{(state, action): {(next_state, outcome): n}}``.

        Pairs never executed take ``fallback``'s deterministic successor.
        """
        distributions = {}
        executions = np.zeros((N_STATES, N_ACTIONS), dtype=np.int64)
        for (state, action), successors in counts.items():
            total = sum(successors.values())
            if total <= 0:
                continue
            executions[state, action] = total
            distributions[(state, action)] = [(s2, out, n / total) for (s2, out), n in sorted(successors.items())]
        return cls._from_distributions(distributions, fallback, source, executions)

    @classmethod
    def _from_distributions(cls, distributions, fallback, source, executions) -> "TransitionTable":
        model_next, model_outcome = fallback.transition_arrays()
        width = max([len(d) for d in distributions.values()] + [1])
        next_state = np.repeat(model_next[..., None], width, axis=2)
        outcome = np.repeat(model_outcome[..., None], width, axis=2)
        cumulative = np.ones((N_STATES, N_ACTIONS, width))
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
        return cls(next_state, outcome, cumulative, source, executions)

    def successors(self, state: int, action: int) -> list[tuple[int, int, float]]:
        """``[(next_state, outcome, probability), ...]`` of one pair."""
        result, previous = [], 0.0
        for k in range(self.max_successors):
            p = float(self.cumulative[state, action, k]) - previous
            previous = float(self.cumulative[state, action, k])
            if p > 0:
                result.append((int(self.next_state[state, action, k]), int(self.outcome[state, action, k]), p))
        return result

    def sample(self, state: int, action: int, draw: float) -> tuple[int, int]:
        """The successor picked by a uniform ``draw`` in [0, 1): ``(next_state, outcome)``."""
        k = 0
        while k < self.max_successors - 1 and draw >= self.cumulative[state, action, k]:
            k += 1
        return int(self.next_state[state, action, k]), int(self.outcome[state, action, k])

    # -- JSON ----------------------------------------------------------------------
    def to_json(self, path: str | Path) -> None:
        """Write the table as JSON (one entry per measured pair, with counts)."""
        pairs = []
        for state in range(N_STATES):
            for action in range(N_ACTIONS):
                pairs.append(
                    {
                        "state": state,
                        "action": Action(action).name.lower(),
                        "executions": int(self.counts[state, action]),
                        "successors": [
                            {"next_state": s2, "outcome": Outcome(out).name.lower(), "probability": p}
                            for s2, out, p in self.successors(state, action)
                        ],
                    }
                )
        document = {"format": FORMAT_NAME, "version": FORMAT_VERSION, "source": self.source, "pairs": pairs}
        Path(path).write_text(json.dumps(document, indent=1))

    @classmethod
    def from_json(cls, path: str | Path, fallback: TaskModel | None = None) -> "TransitionTable":
        """Read a table written by :meth:`to_json`; :class:`CorruptTableError` names what is wrong."""
        path = Path(path)
        try:
            document = json.loads(path.read_text())
        except FileNotFoundError:
            raise
        except (OSError, ValueError) as error:
            raise CorruptTableError(f"{path}: not a JSON transition table ({error})") from None
        if not isinstance(document, dict) or document.get("format") != FORMAT_NAME:
            raise CorruptTableError(f"{path}: 'format' must be {FORMAT_NAME!r}")
        if document.get("version") != FORMAT_VERSION:
            raise CorruptTableError(f"{path}: unsupported version {document.get('version')!r}; expected {FORMAT_VERSION}")
        distributions, executions = {}, np.zeros((N_STATES, N_ACTIONS), dtype=np.int64)
        for index, pair in enumerate(document.get("pairs", [])):
            where = f"{path}: pairs[{index}]"
            try:
                state = int(pair["state"])
                action = Action[str(pair["action"]).upper()]
                successors = [
                    (int(s["next_state"]), Outcome[str(s["outcome"]).upper()], float(s["probability"]))
                    for s in pair["successors"]
                ]
                count = int(pair.get("executions", 0))
            except (KeyError, TypeError, ValueError) as error:
                raise CorruptTableError(f"{where}: malformed entry ({error!r})") from None
            if not 0 <= state < N_STATES:
                raise CorruptTableError(f"{where}: state {state} outside [0, {N_STATES})")
            for s2, _, p in successors:
                if not 0 <= s2 < N_STATES:
                    raise CorruptTableError(f"{where}: next_state {s2} outside [0, {N_STATES})")
                if not 0.0 <= p <= 1.0:
                    raise CorruptTableError(f"{where}: probability {p} outside [0, 1]")
            total = sum(p for _, _, p in successors)
            if successors and abs(total - 1.0) > _PROBABILITY_TOLERANCE:
                raise CorruptTableError(f"{where}: probabilities sum to {total}, not 1")
            if successors:
                distributions[(state, int(action))] = successors
                executions[state, int(action)] = count
        return cls._from_distributions(distributions, fallback or TaskModel(), document.get("source", str(path)), executions)

    def describe_pair(self, state: int, action: int) -> str:
        """One line, e.g. ``'3 pick -> 5 (routine) p=1.00'``."""
        parts = [
            f"{s2} ({Outcome(out).name.lower()}) p={p:.2f}" for s2, out, p in self.successors(state, action)
        ]
        return f"{decode(state).name} {Action(action).name.lower()} -> " + ", ".join(parts)

