"""SkillController: execute task-level actions in physics with the task model's semantics.

``execute(action)`` reads the symbolic state through the environment's
abstraction, refuses improper actions without moving, skips ineffective ones,
and otherwise runs the registered skill until it finishes or exhausts its step
budget; it then reads the symbolic state again and classifies the observed
transition with the task model.
"""

from __future__ import annotations

import time
from typing import Any, Callable, Iterable, Mapping

from tableclean_suite.controllers.fast_control import fast_stepper_of
from tableclean_suite.controllers.osc import check_skill_env
from tableclean_suite.controllers.registry import SKILL_REGISTRY, action_key, get_skill_class
from tableclean_suite.controllers.robot_configs import skill_overrides
from tableclean_suite.controllers.skill import SkillEnv
from tableclean_suite.environments.abstraction import AbstractionError
from tableclean_suite.environments.grippers import gripper_name
from tableclean_suite.skill_result import SkillResult
from tableclean_suite.task import Action, Outcome, TaskModel, TaskState


class SkillController:
    """Runs task-level actions as skills on a ``TableClean`` robosuite env (any task spec it builds).

    Args:
        env: the environment (``skill_info()`` as [`tableclean_suite.environments.TableClean.skill_info`][tableclean_suite.environments.table_clean.TableClean.skill_info],
            ``symbolic_state()``, ``step()``, ``control_freq``), made with
            [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env]; checked at construction
            ([`check_skill_env`][tableclean_suite.controllers.osc.check_skill_env]: ``ValueError`` when its arm
            controller is not absolute world-frame OSC_POSE).
        model: the task model whose rules physics follows (default: the env's ``task_model``, else
            ``TaskModel()``); ints passed to [`execute`][tableclean_suite.controllers.skill_controller.SkillController.execute] index its action list.
        registry: action -> skill class table (default: the global ``SKILL_REGISTRY``).
        skill_configs: per-action config overrides, e.g. ``{Action.CLEAN: {"max_passes": 2}}``; they apply
            on top of the robot's and its gripper's registered overrides ([`robot_configs`][tableclean_suite.controllers.robot_configs],
            by ``env.robots[0].name`` and its gripper's name).
        on_step: called after every ``env.step`` a skill makes (e.g. to record video frames);
            its time counts as executor overhead.  With it every control step runs through
            ``skill.step()`` (the compiled phase loop, which calls no Python per step, is not used).
    """

    def __init__(
        self,
        env: SkillEnv,
        model: TaskModel | None = None,
        registry: Mapping[Action, type] | None = None,
        skill_configs: Mapping[Any, Mapping[str, Any]] | None = None,
        on_step: Callable[[], None] | None = None,
    ):
        check_skill_env(env)
        self.env = env
        if model is None:
            model = getattr(env, "task_model", None)
            model = model if isinstance(model, TaskModel) else TaskModel()
        self.model = model
        self.registry = SKILL_REGISTRY if registry is None else registry
        self.skill_configs = {action_key(a): dict(c) for a, c in (skill_configs or {}).items()}
        #: robosuite's name of the env's robot, whose registered skill overrides apply (see [`skill_config`][tableclean_suite.controllers.skill_controller.SkillController.skill_config])
        self.robot = getattr(env.robots[0], "name", "")
        #: robosuite's name of the env's gripper, whose registered skill overrides apply after the robot's
        self.gripper = gripper_name(env.robots[0])
        self.on_step = on_step

    def skill_config(self, action) -> dict:
        """The config overrides the skill of ``action`` runs with: the robot's, its gripper's, then this
        controller's."""
        key = action_key(action)
        return {**skill_overrides(self.robot, key, self.gripper), **self.skill_configs.get(key, {})}

    def _fast_stepper(self):
        """The env's fast stepper when its env *is* this controller's env, else ``None`` (then ``env.step``): a
        wrapper (e.g. robosuite's ``DataCollectionWrapper``) shows the inner env's stepper, which would bypass
        the wrapper's own ``step()``."""
        stepper = fast_stepper_of(self.env)  # set by make_skill_env(fast_control=True)
        if stepper is None or getattr(stepper, "env", None) is not self.env:
            return None
        return stepper

    def _stepper(self):
        """The function each control step's command goes to: the fast stepper's ``step``, else ``env.step``;
        subclasses may wrap it to see every control step (the compiled phase loop is then not used)."""
        stepper = self._fast_stepper()
        return self.env.step if stepper is None else stepper.step

    def _phase_stepper(self):
        """The fast stepper whose compiled phase loop may run a fixed-waypoint phase's further steps, or ``None``:
        only without ``on_step`` and when `_stepper` is not overridden (both must see every step)."""
        if self.on_step is not None or type(self)._stepper is not SkillController._stepper:
            return None
        return self._fast_stepper()

    def execute(self, action) -> SkillResult:
        """Carry out ``action`` (Action, index into the model's actions, or name) in physics and report what happened.

        Each control step goes through the env's fast stepper when the env owns one
        ([`make_skill_env`][tableclean_suite.controllers.make.make_skill_env] with ``fast_control=True``), else
        ``env.step`` (always through a wrapper, so that its ``step()`` runs).  With a fast stepper
        and no ``on_step``, a phase whose waypoint is fixed continues in the stepper's compiled
        phase loop ([`run_fixed_phase`][tableclean_suite.controllers.skill.Skill.run_fixed_phase]); its time
        counts as time in ``env.step`` (it is the physics, plus the skill's compiled per-step checks).

        Raises ``ValueError`` for an unknown action or when the current state is
        terminal, ``KeyError`` when no skill is registered for the action.
        """
        return self._execute(action, None)

    def _execute(self, action, before: TaskState | None) -> SkillResult:
        """[`execute`][tableclean_suite.controllers.skill_controller.SkillController.execute] from the symbolic state ``before`` when the caller knows it (None: read it now)."""
        start = time.perf_counter()
        action = self.model.action_name(action)  # ValueError naming the allowed actions
        skill_class = get_skill_class(action, self.registry)
        try:
            if before is None:
                before = self.env.symbolic_state()
        except AbstractionError as fault:
            return self._result(action, start, False, 0, f"fault before the action: {fault}", None, None)
        expected, predicted = self.model.step(before, action)  # ValueError when terminal
        if not skill_class.precondition(before, self.model):
            if predicted == Outcome.IMPROPER:
                return self._result(action, start, False, 0, "improper: refused", before, before, improper=True)
            return self._result(action, start, True, 0, f"{predicted.name.lower()}: nothing to do", before, before)

        skill = skill_class(self.env, self.skill_config(action))
        env_step = self._stepper()
        phases = self._phase_stepper()  # runs a fixed-waypoint phase's further steps in compiled code
        env_time = 0.0
        reason = "ok"
        # the skill's own Python the compiled loops call back (the wipe's force reads) is no physics
        callbacks = 0.0 if phases is None else phases.callback_seconds
        try:
            skill.reset(before)
            while (command := skill.step()) is not None:
                tick = time.perf_counter()
                env_step(command)
                if phases is not None and getattr(skill, "fixed_waypoint", None) is not None:
                    skill.run_fixed_phase(phases)
                env_time += time.perf_counter() - tick
                if self.on_step is not None:
                    self.on_step()
            after = self.env.symbolic_state()
        except AbstractionError as fault:
            reason, after = f"fault: {fault}", None
        if phases is not None:
            env_time -= phases.callback_seconds - callbacks
        if skill.failure is not None:
            reason = skill.failure
        elif after is not None and after != expected:
            reason = f"ended in {after.name}, expected {expected.name}"
        success = skill.succeeded and skill_class.is_success(before, after, self.model)
        return self._result(
            action, start, success, skill.steps, reason, before, after,
            env_time=env_time, final_phase=skill.phase.name, phase_steps=dict(skill.phase_steps),
            retries=skill.retries,
        )

    def execute_plan(self, actions: Iterable, stop_on_failure: bool = True) -> list[SkillResult]:
        """Execute ``actions`` in order; stops after the first unsuccessful one if ``stop_on_failure``.

        Also stops once the symbolic state is terminal.  Each action starts from the state the one
        before ended in (nothing moves between two actions; read again after a fault, or when a
        subclass overrides [`execute`][tableclean_suite.controllers.skill_controller.SkillController.execute]).
        """
        results = []
        known = None  # the symbolic state the last action ended in
        reuse = type(self).execute is SkillController.execute
        for action in actions:
            result = self._execute(action, known) if reuse else self.execute(action)
            known = result.state_after
            results.append(result)
            terminal = result.state_after is not None and result.state_after.is_terminal
            if terminal or (stop_on_failure and not result.success):
                break
        return results

    def _result(self, action, start, success, steps, reason, before, after, improper=False, **details):
        expected = None
        outcome = None
        if before is not None:
            expected = self.model.step(before, action)[0]
            if after is not None:
                outcome = self.model.classify(before, action, after)
        return SkillResult(
            action=action,
            success=success,
            improper=improper,
            steps=steps,
            reason=reason,
            state_before=before,
            state_after=after,
            outcome=outcome,
            expected=expected,
            wall_time=time.perf_counter() - start,
            **details,
        )
