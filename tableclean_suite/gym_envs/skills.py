"""``TableCleanSkills-v0``: the task's actions executed by skills in MuJoCo (robosuite is imported when it is made)."""

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
    """The table-cleaning task with each action carried out by a skill in MuJoCo.

    Same task, spaces, rewards and ``info`` as ``TableCleanSymbolic-v0``; each action runs a skill of the
    [`SkillController`][tableclean_suite.controllers.skill_controller.SkillController] (0 to several hundred
    control steps; improper actions are refused without motion) and the next state is read back from the
    physics; the reward applies to that *observed* transition.  Each reset stages the start state in the
    scene, with placement noise seeded by ``self.np_random``.  When the scene maps to no task state the
    episode is truncated: the observation stays the last good state, the reward is 0, ``info["fault"]``
    holds the reason and ``info["outcome"]`` is -1.  ``info["skill_result"]`` is a picklable
    [`SkillReport`][tableclean_suite.skill_result.SkillReport] (equal ignoring timings).

    ```python
    gymnasium.make("TableCleanSkills-v0", reward="r4", task="paper", start=None, render_mode=None,
                   env_kwargs=None, skill_configs=None, camera="frontview", frame_size=(360, 480),
                   robots=None)
    ```
    - ``reward``, ``task``, ``start``, ``model``: as ``TableCleanSymbolic-v0``; specs the scene cannot
      build ([`check_physical_task`][tableclean_suite.physics_backend.check_physical_task]) raise a ``ValueError``.
    - ``render_mode``: ``"ansi"`` or ``"rgb_array"`` (offscreen ``camera`` image of ``frame_size`` =
      (height, width), both >= 16).
    - ``env_kwargs``: overrides of [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env]'s arguments, e.g. ``task_config``.
    - ``skill_configs``: per-action skill config overrides.
    - ``robots``: the arm ([`supported_robots`][tableclean_suite.environments.robot_registry.supported_robots]; default
      ``env_kwargs``'s, else Panda); a ``ValueError`` if it disagrees with ``env_kwargs["robots"]``.
    """

    def __init__(self, reward: str | RewardPattern = "r4", model: TaskModel | None = None,
                 render_mode: str | None = None, env_kwargs: dict | None = None, skill_configs=None,
                 camera: str = "frontview", frame_size: tuple[int, int] = CAMERA_FRAME_SIZE,
                 task: "str | TaskSpec | None" = None, start: str | None = None, robots=None):
        super().__init__(reward=reward, model=model, render_mode=render_mode, task=task, start=start)
        if env_kwargs is not None and not isinstance(env_kwargs, dict):
            raise TypeError(f"env_kwargs must be a dict of robosuite.make arguments, got {type(env_kwargs).__name__}")
        from tableclean_suite.environments.robot_registry import robot_name
        from tableclean_suite.physics_backend import PhysicsStepEnv

        env_kwargs = dict(env_kwargs or {})
        if robots is not None:
            given = env_kwargs.get("robots")
            if given is not None and robot_name(given) != robot_name(robots):
                raise ValueError(f"robots={robots!r} and env_kwargs['robots']={given!r} disagree; give one")
            env_kwargs["robots"] = robots  # checked by make_skill_env, before it builds
        if len(frame_size) != 2 or any(int(n) != n or n < 16 for n in frame_size):
            raise ValueError(f"frame_size must be (height, width) with both >= 16, got {frame_size!r}")
        if render_mode == "rgb_array":
            env_kwargs.setdefault("has_offscreen_renderer", True)
        self.camera = camera
        self.frame_size = (int(frame_size[0]), int(frame_size[1]))
        # the scene and controller PhysicsStepEnv builds (checked by check_physical_task; every reset stages the start)
        scene = PhysicsStepEnv(self.model, env_kwargs, skill_configs)
        self.sim_env, self.controller = scene.env, scene.controller

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        from tableclean_suite.physics_backend import stage

        super().reset(seed=seed)
        state = self._start_state(options)
        stage(self.sim_env, self.controller, state, seed=int(self.np_random.integers(2**63)))
        return self._begin_episode(state)

    def step(self, action):
        action = self._check_action(action)
        result = SkillReport.of(self.controller.execute(action))  # picklable; equal ignoring timings
        if result.state_after is None:
            self.lastaction, self.last_outcome = action, None
            info = self._info()
            info.update(outcome=FAULT_OUTCOME, outcome_name="fault", fault=result.reason, skill_result=result)
            return int(self.s), 0.0, False, True, info
        step = self._transition(action, result.state_after.index, Outcome(result.outcome))
        step[4]["skill_result"] = result
        return step

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
