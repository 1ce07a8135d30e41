"""``TableCleanSymbolic-v0``: the paper's task model as a Gymnasium environment (Taxi-style).

Also holds what the physics env (:mod:`.skills`) shares with it: argument checks, the reward
with the looping penalty's history, ``info``, and the ansi/rgb renderings of a task state.
"""

from __future__ import annotations

import numpy as np
import gymnasium as gym
from gymnasium import spaces

from tableclean_suite.rewards import RewardPattern, get_reward_pattern
from tableclean_suite.task import (
    N_ACTIONS,
    N_STATES,
    Action,
    ObjectLocation,
    Outcome,
    Segment,
    TaskModel,
    TaskState,
    as_action,
    as_state,
    decode,
)

#: Episode length after which the registry's TimeLimit truncates (the paper-faithful max_itr default).
MAX_EPISODE_STEPS = 500
#: ``(height, width)`` of the symbolic ``rgb_array`` frame.
SYMBOLIC_FRAME_SIZE = (240, 480)
_NO_STATE = -1

# colours of the drawn frame (RGB)
_TABLE = (205, 170, 125)
_SEGMENT_TINT = ((190, 205, 235), (240, 205, 170))  # segment 1 blue-ish, segment 2 orange-ish
_DIRT = (110, 80, 40)
_OBJECT = (200, 40, 40)
_ARM = (60, 60, 60)
_TEXT = (20, 20, 20)


class TableCleanBase(gym.Env):
    """Spaces, reward bookkeeping, ``info`` and rendering shared by the symbolic and physics envs."""

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 2}

    def __init__(self, reward: str | RewardPattern = "r4", model: TaskModel | None = None,
                 render_mode: str | None = None):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"unknown render_mode {render_mode!r}; allowed: None, {', '.join(self.metadata['render_modes'])}")
        if model is None:
            model = TaskModel()
        if not isinstance(model, TaskModel):
            raise TypeError(f"model must be a tableclean_suite.task.TaskModel, got {type(model).__name__}")
        self.reward_pattern = get_reward_pattern(reward)  # ValueError names the allowed patterns
        self.model = model
        self.render_mode = render_mode
        self.action_space = spaces.Discrete(N_ACTIONS)
        self.observation_space = spaces.Discrete(N_STATES)
        self.s: int = _NO_STATE  # current state code
        self.previous: int = _NO_STATE  # s_{t-1} for r4's looping penalty (-1 at an episode's first step)
        self.lastaction: Action | None = None
        self.last_outcome: Outcome | None = None

    # -- helpers ---------------------------------------------------------------------------------
    def action_mask(self, state: int | None = None) -> np.ndarray:
        """``(4,)`` int8, 1 where the action is not improper (the task model's mask; all 0 at terminal)."""
        return self.model.action_mask(self.s if state is None else state)

    def _begin_episode(self, state: TaskState):
        """Make ``state`` the current one with no history; returns ``(observation, info)`` for ``reset``."""
        self.s = state.index
        self.previous = _NO_STATE
        self.lastaction = self.last_outcome = None
        return int(self.s), self._info()

    def _start_state(self, options: dict | None) -> TaskState:
        """The start state: ``options["state"]`` (a code or TaskState) or the model's start draw."""
        options = options or {}
        unknown = sorted(set(options) - {"state"})
        if unknown:
            raise ValueError(f"unknown reset option(s) {unknown}; allowed: 'state'")
        if options.get("state") is not None:
            state = as_state(options["state"])
            if state.is_terminal:
                raise ValueError(f"cannot start in the terminal state {state.index} ({state.name})")
            return state
        return self.model.sample_start(float(self.np_random.random()))

    def _check_action(self, action) -> Action:
        if not self.action_space.contains(action) and not isinstance(action, Action):
            raise ValueError(f"action must be in Discrete({N_ACTIONS}) (0 move, 1 pick, 2 place, 3 clean), got {action!r}")
        if self.s == _NO_STATE:
            raise RuntimeError("call reset() before step()")
        if decode(self.s).is_terminal:
            raise RuntimeError("the episode has terminated (both segments clean); call reset()")
        return as_action(int(action))

    def _reward(self, outcome: Outcome, state: int, next_state: int) -> float:
        return float(self.reward_pattern.reward(int(outcome), state, next_state, self.previous))

    def _info(self, outcome: Outcome | None = None) -> dict:
        info = {"action_mask": self.action_mask(), "state_name": decode(self.s).name}
        if outcome is not None:
            info["outcome"] = int(outcome)
            info["outcome_name"] = outcome.name.lower()
        return info

    def _advance(self, state: int, next_state: int, action: Action, outcome: Outcome) -> None:
        self.previous, self.s = state, next_state
        self.lastaction, self.last_outcome = action, outcome

    # -- rendering ---------------------------------------------------------------------------------
    def render(self):
        if self.render_mode is None:
            gym.logger.warn(
                "You are calling render method without specifying any render mode. "
                f'You can specify the render_mode at initialization, e.g. gym.make("{self.spec.id if self.spec else type(self).__name__}", render_mode="ansi")'
            )
            return None
        if self.s == _NO_STATE:
            raise RuntimeError("call reset() before render()")
        if self.render_mode == "ansi":
            return render_text(decode(self.s), self.lastaction, self.last_outcome)
        return self._render_rgb()

    def _render_rgb(self) -> np.ndarray:
        return render_image(decode(self.s), self.lastaction, self.last_outcome)


def render_text(state: TaskState, action: Action | None = None, outcome: Outcome | None = None) -> str:
    """A small text picture of the table, e.g.::

        +------------+------------+
        | S1 ~dirty~ | S2  clean  |
        |    [obj]   |            |
        |    ARM     |            |
        +------------+------------+
        state 0: S1:unclean+obj S2:unclean | arm@S1   last: move (routine)
    """
    width = 12
    cells = {"status": [], "object": [], "arm": []}
    for segment in Segment:
        cells["status"].append(f"S{segment.number} " + ("clean" if state.is_clean(segment) else "~dirty~"))
        cells["object"].append("[obj]" if state.object_location == ObjectLocation.on(segment) else "")
        here = state.arm_segment == segment
        cells["arm"].append(("ARM[obj]" if state.holding else "ARM") if here else "")
    rule = "+" + "+".join("-" * width for _ in Segment) + "+"
    lines = [rule]
    for row in ("status", "object", "arm"):
        lines.append("|" + "|".join(text.center(width) for text in cells[row]) + "|")
    lines.append(rule)
    last = "" if action is None else f"   last: {action.name.lower()}" + (f" ({outcome.name.lower()})" if outcome is not None else "")
    lines.append(f"state {state.index}: {state.name}{last}")
    return "\n".join(lines) + "\n"


def render_image(state: TaskState, action: Action | None = None, outcome: Outcome | None = None,
                 size: tuple[int, int] = SYMBOLIC_FRAME_SIZE) -> np.ndarray:
    """A drawn top view of the task state: ``(height, width, 3)`` uint8."""
    from PIL import Image, ImageDraw

    height, width = size
    image = Image.new("RGB", (width, height), (245, 245, 245))
    draw = ImageDraw.Draw(image)
    margin, gap, text_h = 20, 16, 40
    seg_w = (width - 2 * margin - gap) // 2
    seg_h = height - 2 * margin - text_h
    draw.rectangle([margin - 8, margin - 8, width - margin + 8, margin + seg_h + 8], fill=_TABLE)
    for segment in Segment:
        x0 = margin + segment.value * (seg_w + gap)
        box = [x0, margin, x0 + seg_w, margin + seg_h]
        draw.rectangle(box, fill=_SEGMENT_TINT[segment.value], outline=_TEXT)
        if not state.is_clean(segment):
            rng = np.random.default_rng(7 + segment.value)  # fixed speckle pattern
            for x, y in rng.uniform(0.08, 0.92, size=(18, 2)):
                cx, cy = x0 + x * seg_w, margin + y * seg_h
                draw.ellipse([cx - 4, cy - 4, cx + 4, cy + 4], fill=_DIRT)
        draw.text((x0 + 6, margin + 4), f"S{segment.number} {'clean' if state.is_clean(segment) else 'dirty'}", fill=_TEXT)
        cx, cy = x0 + seg_w / 2, margin + seg_h / 2
        if state.object_location == ObjectLocation.on(segment):
            draw.rectangle([cx - 14, cy + 6, cx + 14, cy + 34], fill=_OBJECT, outline=_TEXT)
        if state.arm_segment == segment:
            # gripper seen from above: a bar with two fingers, holding the object if held
            draw.rectangle([cx - 26, cy - 34, cx + 26, cy - 26], fill=_ARM)
            draw.rectangle([cx - 26, cy - 26, cx - 20, cy - 6], fill=_ARM)
            draw.rectangle([cx + 20, cy - 26, cx + 26, cy - 6], fill=_ARM)
            if state.holding:
                draw.rectangle([cx - 14, cy - 24, cx + 14, cy + 2], fill=_OBJECT, outline=_TEXT)
    caption = f"state {state.index}"
    if action is not None:
        caption += f"   last: {action.name.lower()}" + (f" ({outcome.name.lower()})" if outcome is not None else "")
    draw.text((margin, height - text_h + 4), caption, fill=_TEXT)
    draw.text((margin, height - text_h + 20), state.name, fill=_TEXT)
    return np.asarray(image, dtype=np.uint8)


class TableCleanSymbolicEnv(TableCleanBase):
    """The two-segment table-cleaning task of the paper as a tabular Gymnasium environment.

    ## Description
    A table has two segments, each clean or unclean, and one object lying on a segment or held
    by the robot's gripper; the arm is above one segment.  The sponge has a fixed home, so it is
    not part of the state.  The goal is to clean both segments; an object lying on a segment
    must first be moved away from it.  This environment steps the task model
    (:class:`tableclean_suite.task.TaskModel`); ``TableCleanSkills-v0`` executes the same
    actions with skills in MuJoCo.

    ## Action Space
    ``Discrete(4)``:
    - 0: move (the arm goes to the other segment, carrying a held object)
    - 1: pick (the object on the arm's segment)
    - 2: place (the held object on the arm's segment)
    - 3: clean (the arm's segment)

    ## Observation Space
    ``Discrete(24)``, the state code
    ``((segment1_clean * 2 + segment2_clean) * 3 + object_location) * 2 + arm_segment``
    with cleanliness 0/1, ``object_location`` 0 on segment 1, 1 on segment 2, 2 in the gripper,
    and ``arm_segment`` 0 for segment 1, 1 for segment 2 (:func:`tableclean_suite.task.encode` /
    ``decode``).  From the four both-unclean starts 20 states are reachable (18 non-terminal).

    ## Starting State
    The model's start (default: the paper's Table 1 state 4 = code 0, both unclean, object and
    arm over segment 1; ``TaskModel(start="uniform_unclean")`` draws among the four
    both-unclean layouts with ``self.np_random``).  ``reset(options={"state": code})`` starts
    anywhere non-terminal.

    ## Rewards
    From the reward pattern (default ``"r4"``, Table 2 of the paper):
    - +1 for the clean that makes both segments clean (terminal).
    - +1 for cleaning an unclean segment (r2-r4).
    - -0.01 for cleaning a clean segment, and for an ineffective pick/place.
    - -0.01 (r1, r2) or +0.01 (r3, r4) per move/pick/place.
    - -1 for an improper action (clean while holding the object or where it lies); the state
      does not change (Algorithm 1's failed state).
    - r4: -0.01 instead for a move/pick/place that returns to the state before the previous
      step or leaves the state unchanged (looping penalty; the env keeps s_{t-1}).

    ## Episode End
    - Termination: both segments are clean.
    - Truncation: after 500 steps (``max_episode_steps`` of the registry, the learners'
      ``max_itr`` default).

    ## Information
    ``step`` and ``reset`` return ``info`` with ``"action_mask"`` (``(4,)`` int8, 1 where the
    action is not improper; all 0 at the terminal state), ``"state_name"``, and after a step
    ``"outcome"`` (:class:`tableclean_suite.task.Outcome` code), ``"outcome_name"`` and
    ``"prob"`` (1.0: the model is deterministic).

    ## Arguments
    ```python
    gymnasium.make("TableCleanSymbolic-v0", reward="r4", model=None, render_mode=None)
    ```
    - ``reward``: a registered reward pattern name (``"r1"`` .. ``"r4"`` or a user's) or a
      :class:`tableclean_suite.rewards.RewardPattern`.
    - ``model``: a :class:`tableclean_suite.task.TaskModel` (rules for ineffective actions,
      start states); default ``TaskModel()``.
    - ``render_mode``: ``"ansi"`` (text picture) or ``"rgb_array"`` (drawn top view).

    ## Version History
    - v0: initial version.
    """

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        return self._begin_episode(self._start_state(options))

    def step(self, action):
        action = self._check_action(action)
        state = self.s
        next_state, outcome = self.model.step(state, action)
        reward = self._reward(outcome, state, next_state.index)
        self._advance(state, next_state.index, action, outcome)
        info = self._info(outcome)
        info["prob"] = 1.0
        # truncation=False: the time limit is handled by the registry's TimeLimit wrapper
        return int(self.s), reward, next_state.is_terminal, False, info
