"""``TableCleanSymbolic-v0``: a task spec's model as a Gymnasium environment (Taxi-style), and the base it shares
with the physics env ([`skills`][tableclean_suite.gym_envs.skills]): checks, reward history, ``info``, renderings."""

from __future__ import annotations

import numpy as np
import gymnasium as gym
from gymnasium import spaces

from tableclean_suite.rewards import RewardPattern, get_reward_pattern
from tableclean_suite.task import Outcome, TaskModel, TaskSpec, TaskState
from tableclean_suite.task.state import object_labels

#: Episode length after which the registry's TimeLimit truncates (the paper-faithful max_itr default).
MAX_EPISODE_STEPS = 500
#: ``(height, width)`` of the symbolic ``rgb_array`` frame.
SYMBOLIC_FRAME_SIZE = (240, 480)
_NO_STATE = -1

# colours of the drawn frame (RGB)
_TABLE = (205, 170, 125)
_SEGMENT_TINT = ((190, 205, 235), (240, 205, 170))  # alternating: odd segments blue-ish, even orange-ish
_DIRT = (110, 80, 40)
_OBJECT = (200, 40, 40)
_ARM = (60, 60, 60)
_TEXT = (20, 20, 20)


class TableCleanBase(gym.Env):
    """Spaces, reward bookkeeping, ``info`` and rendering shared by the symbolic and physics envs."""

    metadata = {"render_modes": ["ansi", "rgb_array"], "render_fps": 2}

    def __init__(self, reward: str | RewardPattern = "r4", model: TaskModel | None = None,
                 render_mode: str | None = None, task: "str | TaskSpec | None" = None, start: str | None = None):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"unknown render_mode {render_mode!r}; allowed: None, {', '.join(self.metadata['render_modes'])}")
        if model is not None and not isinstance(model, TaskModel):
            raise TypeError(f"model must be a tableclean_suite.task.TaskModel, got {type(model).__name__}")
        if model is not None and (task is not None or start is not None):
            raise ValueError("give either model= or task=/start=, not both")
        if model is None:
            model = TaskModel(spec=task, start=start)  # ValueError names the allowed specs and start modes
        self.reward_pattern = get_reward_pattern(reward)  # ValueError names the allowed patterns
        self.model = model
        self.render_mode = render_mode
        self.action_space = spaces.Discrete(model.n_actions)
        self.observation_space = spaces.Discrete(model.n_states)
        self.s: int = _NO_STATE  # current state code
        self.history: list[int] = []  # the episode's states s_0 .. s_t, for the looping penalty
        self.lastaction: int | None = None  # index in the task's action order
        self.last_outcome: Outcome | None = None

    def action_masks(self) -> np.ndarray:
        """``(n_actions,)`` bool, True where the action is not improper (all False at the terminal state): sb3-contrib
        ``MaskablePPO``'s interface (vector envs: ``call("action_masks")``); ``RuntimeError`` before ``reset()``."""
        if self.s == _NO_STATE:
            raise RuntimeError("call reset() before action_masks()")
        return self.model.action_mask(self.s).astype(bool)

    def _begin_episode(self, state: TaskState):
        """Make ``state`` the current one with no history; returns ``(observation, info)`` for ``reset``."""
        self.s = state.index
        self.history = [self.s]
        self.lastaction = self.last_outcome = None
        return int(self.s), self._info()

    def _start_state(self, options: dict | None) -> TaskState:
        """The start state: ``options["state"]`` (a code or TaskState) or the model's start draw."""
        options = options or {}
        unknown = sorted(set(options) - {"state"})
        if unknown:
            raise ValueError(f"unknown reset option(s) {unknown}; allowed: 'state'")
        if options.get("state") is not None:
            state = self.model.as_state(options["state"])
            if state.is_terminal:
                raise ValueError(f"cannot start in the terminal state {state.index} ({state.name})")
            return state
        return self.model.sample_start(float(self.np_random.random()))

    def _check_action(self, action) -> int:
        """The action's index; ``ValueError`` names the allowed ones."""
        if not self.action_space.contains(action):
            allowed = ", ".join(f"{i} {name}" for i, name in enumerate(self.model.action_names))
            raise ValueError(f"action must be in Discrete({self.model.n_actions}) ({allowed}), got {action!r}")
        if self.s == _NO_STATE:
            raise RuntimeError("call reset() before step()")
        if self.model.decode(self.s).is_terminal:
            raise RuntimeError("the episode has terminated (every segment clean); call reset()")
        return int(action)

    def _transition(self, action: int, next_state: int, outcome: Outcome) -> tuple:
        """Reward and record the step from ``self.s`` to ``next_state``; ``step``'s 5-tuple (not truncated: the
        registry's TimeLimit truncates)."""
        state = self.s
        previous = self.history[-2] if len(self.history) > 1 else _NO_STATE
        reward = float(self.reward_pattern.reward(int(outcome), state, next_state, previous, self.history))
        self.s = next_state
        self.history.append(next_state)
        self.lastaction, self.last_outcome = action, outcome
        return int(next_state), reward, self.model.decode(next_state).is_terminal, False, self._info(outcome)

    def _info(self, outcome: Outcome | None = None) -> dict:
        info = {"action_mask": self.model.action_mask(self.s), "state_name": self.model.decode(self.s).name}
        if outcome is not None:
            info["outcome"] = int(outcome)
            info["outcome_name"] = outcome.name.lower()
        return info

    def render(self):
        if self.render_mode is None:
            name = self.spec.id if self.spec else type(self).__name__
            gym.logger.warn("You are calling render method without specifying any render mode. You can specify the "
                            f'render_mode at initialization, e.g. gym.make("{name}", render_mode="ansi")')
            return None
        if self.s == _NO_STATE:
            raise RuntimeError("call reset() before render()")
        if self.render_mode == "ansi":
            return render_text(self.model.decode(self.s), self._last_action_name(), self.last_outcome)
        return self._render_rgb()

    def _last_action_name(self) -> str | None:
        return None if self.lastaction is None else self.model.action_names[self.lastaction]

    def _render_rgb(self) -> np.ndarray:
        return render_image(self.model.decode(self.s), self._last_action_name(), self.last_outcome)


def _last_text(action: str | None, outcome: Outcome | None) -> str:
    if action is None:
        return ""
    return f"   last: {action}" + (f" ({outcome.name.lower()})" if outcome is not None else "")


def render_text(state: TaskState, action: str | None = None, outcome: Outcome | None = None) -> str:
    """A small text picture of the table (any number of segments and objects), e.g.:

        +------------+------------+
        | S1 ~dirty~ | S2  clean  |
        |   [obj]    |            |
        |    ARM     |            |
        +------------+------------+
        state 0: S1:unclean+obj S2:unclean | arm@S1   last: move (routine)

    ``action`` is the last action's name (None before the first step).
    """
    width = 12
    cells = {"status": [], "object": [], "arm": []}
    label = object_labels(state.n_objects)
    held = [label[j] for j in range(state.n_objects) if state.objects[j] < 0]
    for k in range(state.n_segments):
        cells["status"].append(f"S{k + 1} " + ("clean" if state.is_clean(k) else "~dirty~"))
        cells["object"].append("".join(f"[{label[j]}]" for j in state.objects_on(k)))
        cells["arm"].append(("ARM" + "".join(f"[{h}]" for h in held)) if state.arm == k else "")
    rule = "+" + "+".join("-" * width for _ in range(state.n_segments)) + "+"
    lines = [rule]
    for row in ("status", "object", "arm"):
        lines.append("|" + "|".join(text.center(width) for text in cells[row]) + "|")
    lines.append(rule)
    lines.append(f"state {state.index}: {state.name}{_last_text(action, outcome)}")
    return "\n".join(lines) + "\n"


def render_image(state: TaskState, action: str | None = None, outcome: Outcome | None = None,
                 size: tuple[int, int] = SYMBOLIC_FRAME_SIZE) -> np.ndarray:
    """A drawn top view of the task state: ``(height, width, 3)`` uint8, one panel per segment."""
    from PIL import Image, ImageDraw

    height, width = size
    image = Image.new("RGB", (width, height), (245, 245, 245))
    draw = ImageDraw.Draw(image)
    margin, gap, text_h = 20, 16, 40
    n = state.n_segments
    seg_w = (width - 2 * margin - (n - 1) * gap) // n
    seg_h = height - 2 * margin - text_h
    box_half = max(4, min(14, seg_w // 8))
    draw.rectangle([margin - 8, margin - 8, width - margin + 8, margin + seg_h + 8], fill=_TABLE)
    for k in range(n):
        x0 = margin + k * (seg_w + gap)
        draw.rectangle([x0, margin, x0 + seg_w, margin + seg_h], fill=_SEGMENT_TINT[k % len(_SEGMENT_TINT)], outline=_TEXT)
        if not state.is_clean(k):
            rng = np.random.default_rng(7 + k)  # fixed speckle pattern per segment
            for x, y in rng.uniform(0.08, 0.92, size=(18, 2)):
                cx, cy = x0 + x * seg_w, margin + y * seg_h
                draw.ellipse([cx - 4, cy - 4, cx + 4, cy + 4], fill=_DIRT)
        draw.text((x0 + 6, margin + 4), f"S{k + 1} {'clean' if state.is_clean(k) else 'dirty'}", fill=_TEXT)
        cx, cy = x0 + seg_w / 2, margin + seg_h / 2
        lying = state.objects_on(k)
        for i, j in enumerate(lying):
            ox = cx + (i - (len(lying) - 1) / 2) * (2 * box_half + 4)
            draw.rectangle([ox - box_half, cy + 6, ox + box_half, cy + 6 + 2 * box_half], fill=_OBJECT, outline=_TEXT)
            if state.n_objects > 1:
                draw.text((ox - box_half + 2, cy + 8), str(j + 1), fill=_TEXT)
        if state.arm == k:
            # gripper seen from above: a bar with two fingers, holding the object if held
            draw.rectangle([cx - 26, cy - 34, cx + 26, cy - 26], fill=_ARM)
            draw.rectangle([cx - 26, cy - 26, cx - 20, cy - 6], fill=_ARM)
            draw.rectangle([cx + 20, cy - 26, cx + 26, cy - 6], fill=_ARM)
            if state.holding:
                draw.rectangle([cx - box_half, cy - 24, cx + box_half, cy + 2], fill=_OBJECT, outline=_TEXT)
    caption = f"state {state.index}{_last_text(action, outcome)}"
    draw.text((margin, height - text_h + 4), caption, fill=_TEXT)
    draw.text((margin, height - text_h + 20), state.name, fill=_TEXT)
    return np.asarray(image, dtype=np.uint8)


class TableCleanSymbolicEnv(TableCleanBase):
    """A table-cleaning task spec (default the paper's) as a tabular Gymnasium environment that steps
    the [`TaskModel`][tableclean_suite.task.model.TaskModel] (whose docstring states the rules).

    - Actions: ``Discrete(A)``, the spec's actions in order (the paper's: 0 move, 1 pick, 2 place, 3 clean).
    - Observations: ``Discrete(S)``, the state code ([`encode`][tableclean_suite.task.state.encode]; the
      paper's ``Discrete(24)``; ``env.unwrapped.model.decode(code)`` gives the state).
    - Start: the spec's (the paper: Table 1's state 4 = code 0); ``start="uniform_unclean"`` draws with
      ``self.np_random``; ``reset(options={"state": code})`` starts in any non-terminal state.
    - Reward: the reward pattern's value of each step's outcome (default ``"r4"``, the paper's Table 2).
    - End: terminated when every segment is clean, truncated after 500 steps.
    - ``info``: ``"action_mask"`` (``(A,)`` int8, 1 where not improper), ``"state_name"``, and after a
      step ``"outcome"`` ([`Outcome`][tableclean_suite.task.state.Outcome] code), ``"outcome_name"`` and
      ``"prob"`` (1.0); all picklable.

    ```python
    gymnasium.make("TableCleanSymbolic-v0", reward="r4", task="paper", start=None, render_mode=None)
    ```
    - ``task``: a registered spec name, a [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] or a ``.json`` path.
    - ``start``: ``"fixed"`` or ``"uniform_unclean"``; None keeps the spec's.
    - ``reward``: a registered reward pattern name or a [`RewardPattern`][tableclean_suite.rewards.RewardPattern].
    - ``model``: a ready [`TaskModel`][tableclean_suite.task.model.TaskModel] instead of ``task``/``start``.
    - ``render_mode``: ``"ansi"`` (text picture) or ``"rgb_array"`` (drawn top view).
    """

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        return self._begin_episode(self._start_state(options))

    def step(self, action):
        action = self._check_action(action)
        next_state, outcome = self.model.step(self.s, action)
        result = self._transition(action, next_state.index, outcome)
        result[4]["prob"] = 1.0
        return result
