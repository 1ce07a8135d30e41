"""What one skill execution did, as plain data: picklable, and importable without robosuite.

[`SkillResult`][tableclean_suite.skill_result.SkillResult] is what [`tableclean_suite.controllers.SkillController.execute`][tableclean_suite.controllers.skill_controller.SkillController.execute] returns;
[`SkillReport`][tableclean_suite.skill_result.SkillReport] is the same record compared without its wall-clock timings, as the Gym skill
env puts it in ``info["skill_result"]`` (``info`` must cross process boundaries, e.g. Gymnasium's
``AsyncVectorEnv``, and be equal for equal seeds and actions).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

from tableclean_suite.task import Outcome, TaskState

#: SkillResult fields that measure wall-clock time (not part of what physics did).
TIMING_FIELDS = ("wall_time", "env_time")


@dataclass(frozen=True)
class SkillResult:
    """What one ``SkillController.execute`` call did (a record: immutable).

    Attributes:
        action: the executed action's registered name (``"pick"``, ``"transfer"``), for built-in and
            user actions alike (``TaskModel.action_index`` turns it into the spec's index).
        success: the symbolic state after equals the task model's successor (and the skill finished).
        improper: the task model calls the action improper here; refused, nothing moved.
        steps: control steps (``env.step`` calls) used; 0 for refused and ineffective actions.
        reason: short human-readable account ("ok", "improper: ...", failure cause, ...).
        state_before: symbolic state before the action.
        state_after: symbolic state after it; ``None`` when the abstraction reported a fault.
        outcome: [`Outcome`][tableclean_suite.task.state.Outcome] of the observed transition (``TaskModel.classify``); ``None`` on a fault.
        expected: the task model's successor of ``state_before``.
        wall_time: seconds spent in ``execute`` (including abstraction reads).
        env_time: seconds of that spent inside ``env.step`` (or the env's fast stepper, see ``execute``).
        final_phase: name of the skill's last phase ("" when no skill ran).
        phase_steps: control steps spent per phase name (empty when no skill ran).
        retries: times the skill re-measured the scene and started a failed grasp, place or wipe again
            (0 when it succeeded the first time or no skill ran; at most its config's ``retries``).
    """

    action: str
    success: bool
    improper: bool
    steps: int
    reason: str
    state_before: TaskState | None
    state_after: TaskState | None
    outcome: Outcome | None
    expected: TaskState | None = None
    wall_time: float = 0.0
    env_time: float = 0.0
    final_phase: str = ""
    phase_steps: dict = field(default_factory=dict)
    retries: int = 0


@dataclass(frozen=True, eq=False)
class SkillReport(SkillResult):
    """A [`SkillResult`][tableclean_suite.skill_result.SkillResult] as the Gym skill env reports it (``info["skill_result"]``).

    It compares equal to another report or ``SkillResult`` ignoring the wall-clock timings:
    ``info`` must be equal for equal seeds and actions (Gymnasium's determinism check), and
    the timings of two identical executions never are.
    """

    __hash__ = None  # phase_steps is a dict

    @classmethod
    def of(cls, result) -> "SkillReport":
        """The report of a ``SkillResult`` (``phase_steps`` copied)."""
        values = {f.name: getattr(result, f.name) for f in fields(cls)}
        values["phase_steps"] = dict(values["phase_steps"])
        return cls(**values)

    def __eq__(self, other):
        names = [f.name for f in fields(self) if f.name not in TIMING_FIELDS]
        if not all(hasattr(other, name) for name in names):
            return NotImplemented
        return all(getattr(self, name) == getattr(other, name) for name in names)
