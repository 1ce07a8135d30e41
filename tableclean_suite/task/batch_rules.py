"""The built-in actions' rules (move, pick, place, clean), written once as array arithmetic on the
digits of state codes ([`encode`][tableclean_suite.task.state.encode]): one rule serves every code at
once ([`TaskModel.transition_arrays`][tableclean_suite.task.model.TaskModel.transition_arrays]) and
one state ([`move_effect`][tableclean_suite.task.actions.move_effect], ...).
[`batch_step`][tableclean_suite.task.batch_rules.batch_step] adds the model's conventions.
"""

from __future__ import annotations

import numpy as np

from tableclean_suite.task.state import CLEAN_RADIX, Outcome

#: No object index (``first`` below: no object satisfies the condition).
_NONE = -1


class StateDigits:
    """The digits of state codes of an N-segment, M-object task.

    Attributes:
        codes: ``(K,)`` int64 the codes (every code ``0..S-1`` by default).
        arm: ``(S,)`` int64 arm segment index.
        where: ``(M, S)`` int64 object locations (0..N-1, or N for held).
        clean_bits: ``(S,)`` int64, the clean flags as a binary number (segment 1 most significant).
        object_weight: ``(M,)`` place value of each object's digit in the code.
        clean_weight: ``(N,)`` place value of each segment's clean flag in the code.
    """

    def __init__(self, n_segments: int, n_objects: int, n_states: int, codes: np.ndarray | None = None):
        self.n_segments, self.n_objects = n_segments, n_objects
        self.codes = np.arange(n_states, dtype=np.int64) if codes is None else np.asarray(codes, dtype=np.int64)
        n_states = self.codes.shape[0]
        rest, self.arm = np.divmod(self.codes, n_segments)
        where = []
        for _ in range(n_objects):
            rest, digit = np.divmod(rest, n_segments + 1)
            where.append(digit)
        self.where = np.array(where[::-1], dtype=np.int64).reshape(n_objects, n_states)
        self.clean_bits = rest
        object_weight = [n_segments * (n_segments + 1) ** (n_objects - 1 - j) for j in range(n_objects)]
        self.object_weight = np.array(object_weight, dtype=np.int64)
        base = n_segments * (n_segments + 1) ** n_objects
        self.clean_weight = np.array([base * CLEAN_RADIX ** (n_segments - 1 - k) for k in range(n_segments)],
                                     dtype=np.int64)
        self.all_clean = CLEAN_RADIX**n_segments - 1

    @property
    def terminal(self) -> np.ndarray:
        """``(S,)`` bool: every segment clean."""
        return self.clean_bits == self.all_clean

    @property
    def held(self) -> np.ndarray:
        """``(M, S)`` bool: object j is held."""
        return self.where == self.n_segments

    def first(self, condition: np.ndarray) -> np.ndarray:
        """``(S,)`` int64: the lowest object index where ``condition`` (``(M, S)``) holds, else -1."""
        found = condition.any(axis=0)
        return np.where(found, condition.argmax(axis=0), _NONE)


def move(d: StateDigits):
    """MOVE: the arm goes to the next segment, k -> k + 1 (N -> 1); a held object goes along. ROUTINE."""
    next_codes = d.codes - d.arm + (d.arm + 1) % d.n_segments
    return next_codes, np.full(d.codes.shape, Outcome.ROUTINE, dtype=np.int64)


def pick(d: StateDigits):
    """PICK: with nothing held, the lowest-numbered object on the arm's segment is held (ROUTINE);
    else INEFFECTIVE."""
    holding = d.held.any(axis=0)
    lying = d.first(d.where == d.arm[None, :])
    effective = ~holding & (lying != _NONE)
    weight = d.object_weight[np.maximum(lying, 0)]
    next_codes = np.where(effective, d.codes + (d.n_segments - d.arm) * weight, d.codes)
    outcome = np.where(effective, Outcome.ROUTINE, Outcome.INEFFECTIVE).astype(np.int64)
    return next_codes, outcome


def place(d: StateDigits):
    """PLACE: the held object comes to lie on the arm's segment (ROUTINE); else INEFFECTIVE."""
    held = d.first(d.held)
    effective = held != _NONE
    weight = d.object_weight[np.maximum(held, 0)]
    next_codes = np.where(effective, d.codes + (d.arm - d.n_segments) * weight, d.codes)
    outcome = np.where(effective, Outcome.ROUTINE, Outcome.INEFFECTIVE).astype(np.int64)
    return next_codes, outcome


def clean(d: StateDigits):
    """CLEAN: IMPROPER when holding or when any object lies on the arm's segment; else the arm's
    segment becomes clean (RELEVANT_CLEAN) or already was (IRRELEVANT_CLEAN)."""
    improper = d.held.any(axis=0) | (d.where == d.arm[None, :]).any(axis=0)
    already = ((d.clean_bits >> (d.n_segments - 1 - d.arm)) & 1).astype(bool)  # the arm's segment is clean
    relevant = ~improper & ~already
    next_codes = np.where(relevant, d.codes + d.clean_weight[d.arm], d.codes)
    outcome = np.select([improper, already], [Outcome.IMPROPER, Outcome.IRRELEVANT_CLEAN],
                        Outcome.RELEVANT_CLEAN).astype(np.int64)
    return next_codes, outcome


def batch_step(digits: StateDigits, rule, improper_ineffective: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(next codes, outcomes, the rule's own outcomes)``, each ``(S,)`` int64, of a built-in
    ``rule`` ([`move`][tableclean_suite.task.batch_rules.move], ...) from every code.  The second has
    the model's conventions: INEFFECTIVE becomes IMPROPER with ``improper_ineffective``, an action
    that leaves every segment clean is TERMINAL, terminal codes map to themselves with TERMINAL."""
    next_codes, outcome = rule(digits)
    raw = outcome.copy()
    if improper_ineffective:
        outcome[outcome == Outcome.INEFFECTIVE] = Outcome.IMPROPER
    next_clean = next_codes // digits.clean_weight[-1]
    outcome[next_clean == digits.all_clean] = Outcome.TERMINAL
    terminal = digits.terminal
    next_codes[terminal] = digits.codes[terminal]
    outcome[terminal] = Outcome.TERMINAL
    return next_codes, outcome, raw
