"""``TableCleanSkills-v0``: the task's actions executed by skills in MuJoCo, as a Gymnasium env (any spec the scene builds).

robosuite and the skills are imported when the env is made, not when this module is imported.
"""

from __future__ import annotations

import numpy as np

from tableclean_suite.gym_envs.symbolic import TableCleanBase
from tableclean_suite.rewards import RewardPattern
from tableclean_suite.skill_result import SkillReport
from tableclean_suite.task import Outcome, TaskModel, TaskSpec

#: Default size ``(height, width)`` of the ``rgb_array`` camera frame.
CAMERA_FRAME_SIZE = (360, 480)
#: ``info["outcome"]`` when the abstraction reported a fault (no task state was observed).
FAULT_OUTCOME = -1


class TableCleanSkillsEnv(TableCleanBase):
    """The table-cleaning task with each action carried out by a Panda skill in MuJoCo.

    ## Description
    Same task, spaces and rewards as ``TableCleanSymbolic-v0``, but every action runs a skill
    of [`tableclean_suite.controllers.SkillController`][tableclean_suite.controllers.skill_controller.SkillController] (move, pick, place, clean with a
    sponge) on the ``TableClean`` robosuite scene under OSC_POSE control, and the next state is
    read back from the physics through the environment's abstraction.  Improper actions are
    refused without motion and ineffective ones do nothing, as in the task model.  One step
    takes from 0 (refused) to several hundred control steps.

    ## Action Space
    ``Discrete(A)``, the spec's actions in its order; the paper's: 0 move, 1 pick, 2 place, 3 clean.

    ## Observation Space
    ``Discrete(n_states)`` of the spec; for the ``paper`` spec ``Discrete(24)``, the state code
    ``((segment1_clean * 2 + segment2_clean) * 3 + object_location) * 2 + arm_segment`` with
    0-based segments and object location 2 for held
    ([`tableclean_suite.task.encode`][tableclean_suite.task.state.encode]; see ``TableCleanSymbolic-v0``), read from the physics.

    ## Starting State
    The model's start state (default Table 1 state 4: both unclean, object and arm over segment
    1) staged in the scene: the robosuite env is reset with that layout (``object_segment``,
    ``arm_segment``, dirty segments; a held object is picked up), with the object's placement
    noise drawn from a generator seeded by ``self.np_random``.  ``reset(options={"state":
    code})`` stages any non-terminal state.

    ## Rewards
    The reward pattern (default ``"r4"``) applied to the *observed* transition: the outcome is
    ``TaskModel.classify(state, action, observed_next_state)``; r4's looping penalty uses the
    env's record of s_{t-1}.  See ``TableCleanSymbolic-v0`` for the values.

    ## Episode End
    - Termination: the physics reads both segments clean.
    - Truncation: after 500 steps (registry ``max_episode_steps``), or at once when the
      abstraction reports a fault (the scene maps to no task state, e.g. the object was dropped
      between the segments): the observation stays the last good state, the reward is 0,
      ``info["fault"]`` holds the reason and ``info["outcome"]`` is -1.  Nothing is mapped to a
      state that was not observed.

    ## Information
    As ``TableCleanSymbolic-v0`` (``"action_mask"``, ``"state_name"``, ``"outcome"``,
    ``"outcome_name"``) plus ``"skill_result"``: a [`SkillReport`][tableclean_suite.skill_result.SkillReport], the picklable
    snapshot of the [`SkillResult`][tableclean_suite.skill_result.SkillResult] (success, improper,
    steps, reason, states before/after, wall time; it compares equal ignoring the timings), and
    ``"fault"`` on a fault.  Everything in ``info`` pickles (``AsyncVectorEnv`` works);
    ``action_masks()`` gives the mask as bools for sb3-contrib's MaskablePPO.

    ## Arguments
    ```python
    gymnasium.make("TableCleanSkills-v0", reward="r4", task="paper", start=None, render_mode=None,
                   env_kwargs=None, skill_configs=None, camera="frontview", frame_size=(360, 480),
                   robots=None)
    ```
    - ``reward``, ``task``, ``start``, ``model``: as ``TableCleanSymbolic-v0``; the physical scene
      builds N <= 4 segments, objects of registered types, and actions with registered skills
      ([`tableclean_suite.physics_backend.check_physical_task`][tableclean_suite.physics_backend.check_physical_task]); other specs are refused
      with a ``ValueError`` naming the limit.
    - ``render_mode``: ``"ansi"`` (text picture of the observed state) or ``"rgb_array"``
      (offscreen camera image, ``frame_size`` = (height, width)).
    - ``env_kwargs``: overrides of ``robosuite.make`` arguments
      ([`tableclean_suite.controllers.make_skill_env`][tableclean_suite.controllers.make.make_skill_env]), e.g. ``task_config``.
    - ``skill_configs``: per-action skill config overrides for the SkillController.
    - ``camera``: camera of the ``rgb_array`` frames.
    - ``robots``: the arm (a robot with a registered skill config,
      [`tableclean_suite.controllers.robot_configs.supported_robots`][tableclean_suite.environments.robot_registry.supported_robots]; default ``env_kwargs``'s,
      else Panda); checked before the scene is built (``ValueError`` naming the supported ones);
      giving it both here and in ``env_kwargs`` with different values is a ``ValueError``.

    ## Version History
    - v0: initial version (v0 also builds any spec the scene can: N <= 4 segments, M objects).
    """

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 2}

    def __init__(self, reward: str | RewardPattern = "r4", model: TaskModel | None = None,
                 render_mode: str | None = None, env_kwargs: dict | None = None, skill_configs=None,
                 camera: str = "frontview", frame_size: tuple[int, int] = CAMERA_FRAME_SIZE,
                 task: "str | TaskSpec | None" = None, start: str | None = None, robots=None):
        super().__init__(reward=reward, model=model, render_mode=render_mode, task=task, start=start)
        if env_kwargs is not None and not isinstance(env_kwargs, dict):
            raise TypeError(f"env_kwargs must be a dict of robosuite.make arguments, got {type(env_kwargs).__name__}")
        if robots is not None:
            from tableclean_suite.controllers.robot_configs import robot_name

            given = (env_kwargs or {}).get("robots")
            if given is not None and robot_name(given) != robot_name(robots):
                raise ValueError(f"robots={robots!r} and env_kwargs['robots']={given!r} disagree; give one")
            env_kwargs = {**(env_kwargs or {}), "robots": robots}  # checked by make_skill_env, before it builds
        from tableclean_suite.physics_backend import check_physical_task

        check_physical_task(self.model, (env_kwargs or {}).get("task_config"))
        if len(frame_size) != 2 or any(int(n) != n or n < 16 for n in frame_size):
            raise ValueError(f"frame_size must be (height, width) with both >= 16, got {frame_size!r}")
        from tableclean_suite.controllers import SkillController, make_skill_env
        from tableclean_suite.physics_backend import staging_env_kwargs

        kwargs = staging_env_kwargs(self.model, env_kwargs)  # every reset stages the start itself
        if render_mode == "rgb_array":
            kwargs.setdefault("has_offscreen_renderer", True)
        self.camera = camera
        self.frame_size = (int(frame_size[0]), int(frame_size[1]))
        self.sim_env = make_skill_env(**kwargs)
        self.controller = SkillController(self.sim_env, self.model, skill_configs=skill_configs)
        self.last_skill_result = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        from tableclean_suite.physics_backend import stage

        super().reset(seed=seed)
        state = self._start_state(options)
        stage(self.sim_env, self.controller, state, seed=int(self.np_random.integers(2**63)))
        return self._begin_episode(state)

    def step(self, action):
        action = self._check_action(action)
        state = self.s
        result = SkillReport.of(self.controller.execute(action))  # picklable; equal ignoring timings
        self.last_skill_result = result
        if result.state_after is None:
            self.lastaction, self.last_outcome = action, None
            info = self._info()
            info.update(outcome=FAULT_OUTCOME, outcome_name="fault", fault=result.reason, skill_result=result)
            return int(self.s), 0.0, False, True, info
        next_state, outcome = result.state_after.index, Outcome(result.outcome)
        reward = self._reward(outcome, state, next_state)
        self._advance(state, next_state, action, outcome)
        info = self._info(outcome)
        info["skill_result"] = result
        return int(self.s), reward, self.model.decode(next_state).is_terminal, False, info

    def _render_rgb(self) -> np.ndarray:
        height, width = self.frame_size
        frame = self.sim_env.sim.render(camera_name=self.camera, width=width, height=height)
        return np.ascontiguousarray(frame[::-1])

    def close(self):
        env = getattr(self, "sim_env", None)
        if env is not None:
            env.close()
            self.sim_env = None
        super().close()
