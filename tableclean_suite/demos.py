"""Demonstration datasets of the skills in robomimic's hdf5 layout: record, write (atomically), read, rebuild.

A dataset holds skill executions in the ``TableClean`` scene, one sample per control step: per demo
``states`` (T, D) before each action, ``actions`` (T, 7) absolute OSC_POSE commands, ``rewards``,
``dones``, ``obs``/``next_obs`` observables, the task-state codes read from the states and which plan
entry was executing; ``data.attrs["env_args"]`` rebuilds the scene.  The full layout, every dataset and
attribute with its shape and units, is on the documentation's Datasets page (``docs/datasets.md``).

Only recording needs robosuite and MuJoCo; [`read_demo`][tableclean_suite.demos.read_demo] and
[`read_env_args`][tableclean_suite.demos.read_env_args] need h5py only.
"""

from __future__ import annotations

import datetime
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from tableclean_suite.robosuite_adapter import fresh_observations

#: robomimic's ``EnvType.ROBOSUITE_TYPE`` (``env_args["type"]``).
ROBOSUITE_ENV_TYPE = 1
#: The robosuite environment the demos are recorded in.
ENV_NAME = "TableClean"
#: Length of a skill command: absolute OSC_POSE (position m, axis-angle rad) + gripper.
ACTION_DIM = 7
#: Environment observables written under ``obs/`` and ``next_obs/`` (those the env has).
OBS_KEYS = ("robot0_eef_pos", "robot0_eef_quat", "robot0_gripper_qpos", "object_pos", "object_quat",
            "objects_pos", "objects_quat", "sponge_pos", "dirt_fraction", "symbolic_state_index")
#: Code of ``symbolic_states`` for a state that maps to no task state (TableClean's ``FAULT_INDEX``).
NO_TASK_STATE = -1
#: Fraction of the demos in ``mask/valid`` (at least one when there are two or more demos).
VALID_FRACTION = 0.1
#: Per-demo datasets of one entry per sample (checked to have ``num_samples`` rows).
PER_SAMPLE_DATASETS = ("states", "actions", "rewards", "dones", "symbolic_states", "skill_index", "skill_action")


@dataclass
class Demo:
    """One recorded demonstration: the arrays and attributes of a ``demo_k`` group (shapes: the dataset
    layout; ``attrs``' JSON values decoded)."""

    states: np.ndarray
    actions: np.ndarray
    rewards: np.ndarray
    dones: np.ndarray
    obs: dict
    next_obs: dict
    symbolic_states: np.ndarray
    skill_index: np.ndarray
    skill_action: np.ndarray
    skill_bounds: np.ndarray
    final_state: np.ndarray
    attrs: dict = field(default_factory=dict)

    @property
    def num_samples(self) -> int:
        """T, the number of control steps."""
        return int(len(self.actions))

    def check(self) -> None:
        """``ValueError`` naming the first array whose shape does not fit ``num_samples`` and the others."""
        n = self.num_samples
        if self.actions.shape != (n, ACTION_DIM):
            raise ValueError(f"actions must have shape (T, {ACTION_DIM}), got {self.actions.shape}")
        if self.states.ndim != 2 or self.final_state.shape != self.states.shape[1:]:
            raise ValueError(f"states must be (T, D) and final_state (D,), got {self.states.shape} and {self.final_state.shape}")
        rows = {name: getattr(self, name) for name in PER_SAMPLE_DATASETS}
        rows.update({f"{group}/{key}": value for group in ("obs", "next_obs") for key, value in getattr(self, group).items()})
        for name, value in rows.items():
            if len(value) != n:
                raise ValueError(f"{name} has {len(value)} rows, expected num_samples = {n}")
        if self.skill_bounds.ndim != 2 or self.skill_bounds.shape[1] != 2:
            raise ValueError(f"skill_bounds must have shape (K, 2), got {self.skill_bounds.shape}")


# env_args: what rebuilds the scene
def env_args_of(env, task: str, controller_configs: dict) -> dict:
    """robomimic's ``env_args`` of a skill env made by [`make_skill_env`][tableclean_suite.controllers.make.make_skill_env]
    (``task``: a spec name or ``.json`` path; ``controller_configs``: the env's): ``robosuite.make("TableClean",
    **env_kwargs)`` rebuilds the same model."""
    import robosuite

    from tableclean_suite.controllers.make import SKILL_ENV_DEFAULTS
    from tableclean_suite.environments.config import jsonable

    meta = env.get_ep_meta()
    kwargs = dict(SKILL_ENV_DEFAULTS)
    kwargs.update(
        robots=[robot.name for robot in env.robots][0],
        controller_configs=jsonable(controller_configs),
        task=str(task),
        task_config=meta["task_config"],
        control_freq=float(env.control_freq),
        use_object_obs=bool(env.use_object_obs),
        object_segment=1,
        arm_segment=1,
    )
    return {"env_name": ENV_NAME, "env_version": robosuite.__version__, "type": ROBOSUITE_ENV_TYPE, "env_kwargs": kwargs}


def make_env_from_args(env_args: dict, **overrides):
    """``robosuite.make(env_args["env_name"], **env_args["env_kwargs"], **overrides)`` (registers TableClean first)."""
    import robosuite

    import tableclean_suite  # noqa: F401  (registers TableClean)

    if env_args.get("type") != ROBOSUITE_ENV_TYPE:
        raise ValueError(f"env_args['type'] must be {ROBOSUITE_ENV_TYPE} (robosuite), got {env_args.get('type')!r}")
    return robosuite.make(env_args["env_name"], **{**env_args["env_kwargs"], **overrides})


# recording
class EpisodeRecorder:
    """Records the state before and the command of every control step of a
    [`recording_controller`][tableclean_suite.demos.recording_controller]; [`finish`][tableclean_suite.demos.EpisodeRecorder.finish]
    makes the [`Demo`][tableclean_suite.demos.Demo] (observables read by restoring each state, as a replay reads them)."""

    def __init__(self, env):
        self.env = env
        self.states: list[np.ndarray] = []
        self.actions: list[np.ndarray] = []
        self.skill_index: list[int] = []
        self.skill_action: list[int] = []
        self.bounds: list[list[int]] = []
        self.plan: list[str] = []
        self.hook_steps = 0  # control steps seen by the controller's on_step hook (a cross-check)
        self._current = (-1, -1)

    def begin(self, action_name: str, action_index: int) -> None:
        """The next control steps belong to a new plan entry executing ``action_name``."""
        self._current = (len(self.plan), int(action_index))
        self.plan.append(action_name)
        self.bounds.append([len(self.actions), len(self.actions)])

    def before_step(self, command) -> None:
        """Called with each command just before the control step runs."""
        self.states.append(np.array(self.env.sim.get_state().flatten()))
        self.actions.append(np.array(command, dtype=float))
        self.skill_index.append(self._current[0])
        self.skill_action.append(self._current[1])
        if self.bounds:
            self.bounds[-1][1] = len(self.actions)

    def on_step(self) -> None:
        """The SkillController's ``on_step`` hook (after each control step)."""
        self.hook_steps += 1

    def finish(self, attrs: dict | None = None) -> Demo:
        """The [`Demo`][tableclean_suite.demos.Demo] of the steps so far (the env left in the final state);
        ``RuntimeError`` when a control path bypassed the recording."""
        from tableclean_suite.environments.abstraction import AbstractionError
        from tableclean_suite.environments.config import jsonable

        if self.hook_steps != len(self.actions):
            raise RuntimeError(f"recorded {len(self.actions)} commands but the controller made {self.hook_steps} "
                               "control steps: a control path bypassed the recorder")
        env = self.env
        final_state = np.array(env.sim.get_state().flatten())
        observations: dict[str, list] = {}
        codes, success = [], []
        for index, state in enumerate(self.states + [final_state]):
            env.sim.set_state_from_flattened(state)
            env.sim.forward()
            obs = fresh_observations(env)
            for key in OBS_KEYS:
                if key in obs:
                    observations.setdefault(key, []).append(np.atleast_1d(np.asarray(obs[key], dtype=float)))
            try:
                codes.append(env.symbolic_state(check_sponge=False).index)
            except AbstractionError:
                codes.append(NO_TASK_STATE)
            success.append(bool(env._check_success()) if index > 0 else False)
        n = len(self.actions)
        stacked = {key: np.stack(values) for key, values in observations.items()}
        terminal = codes[-1] != NO_TASK_STATE and env.task_model.decode(codes[-1]).is_terminal
        demo_attrs = {**(attrs or {}), "plan": list(self.plan), "final_symbolic_state": int(codes[-1]),
                      "success": bool(success[-1]) and terminal, "model_file": env.sim.model.get_xml(),
                      "ep_meta": jsonable(env.get_ep_meta())}
        return Demo(
            states=np.array(self.states, dtype=float).reshape(n, final_state.shape[0]),
            actions=np.array(self.actions, dtype=float).reshape(n, ACTION_DIM),
            rewards=np.array(success[1:], dtype=float), dones=(np.arange(n) == n - 1).astype(np.int64),
            obs={key: value[:-1] for key, value in stacked.items()},
            next_obs={key: value[1:] for key, value in stacked.items()},
            symbolic_states=np.array(codes[:-1], dtype=np.int64),
            skill_index=np.array(self.skill_index, dtype=np.int64),
            skill_action=np.array(self.skill_action, dtype=np.int64),
            skill_bounds=np.array(self.bounds, dtype=np.int64).reshape(-1, 2), final_state=final_state,
            attrs=demo_attrs)


def recording_controller(env, model, recorder: EpisodeRecorder):
    """A [`SkillController`][tableclean_suite.controllers.skill_controller.SkillController] whose every control
    step ``recorder`` sees, on the fast control path too (which bypasses ``env.step``)."""
    from tableclean_suite.controllers import SkillController

    class RecordingSkillController(SkillController):
        def _stepper(self):
            step = super()._stepper()

            def recorded_step(command):
                recorder.before_step(command)
                return step(command)

            return recorded_step

    return RecordingSkillController(env, model, on_step=recorder.on_step)


# writing and reading
def split_keys(keys: Sequence[str], valid_fraction: float = VALID_FRACTION, seed: int = 0) -> tuple[list[str], list[str]]:
    """``(train, valid)`` demo keys: ``round(valid_fraction * n)`` (at least 1 when n >= 2) drawn with ``seed``."""
    if not 0.0 <= valid_fraction < 1.0:
        raise ValueError(f"valid_fraction must be in [0, 1), got {valid_fraction!r}")
    keys = list(keys)
    n_valid = int(round(valid_fraction * len(keys)))
    if len(keys) >= 2 and valid_fraction > 0:
        n_valid = max(1, n_valid)
    chosen = set(np.random.default_rng(seed).choice(len(keys), size=n_valid, replace=False).tolist()) if n_valid else set()
    return [k for i, k in enumerate(keys) if i not in chosen], [k for i, k in enumerate(keys) if i in chosen]


def write_dataset(path, demos: Sequence[Demo], env_args: dict, attrs: dict | None = None,
                  valid_fraction: float = VALID_FRACTION, seed: int = 0) -> Path:
    """Write ``demos`` to ``path`` (hdf5, the module's layout) atomically; returns ``path``.  ``attrs`` are extra
    ``data`` attributes (dicts and lists stored as JSON); ``ValueError`` naming a demo of inconsistent shapes."""
    import h5py
    import robosuite

    import tableclean_suite
    from tableclean_suite.atomic_files import atomic_write

    for index, demo in enumerate(demos):
        try:
            demo.check()
        except ValueError as error:
            raise ValueError(f"demo {index}: {error}") from None
    keys = [f"demo_{k}" for k in range(len(demos))]
    train, valid = split_keys(keys, valid_fraction, seed)
    env_info = {"env_name": env_args["env_name"],
                **{k: env_args["env_kwargs"][k] for k in ("robots", "controller_configs", "task", "task_config")}}

    def write(temporary: Path) -> None:
        with h5py.File(temporary, "w") as f:
            data = f.create_group("data")
            data.attrs.update({
                "env_args": json.dumps(env_args), "env": env_args["env_name"], "env_info": json.dumps(env_info),
                "total": int(sum(d.num_samples for d in demos)),
                "date": datetime.datetime.now().isoformat(timespec="seconds"),
                "repository_version": robosuite.__version__,
                "tableclean_version": getattr(tableclean_suite, "__version__", ""),
                **{name: _attr_value(value) for name, value in (attrs or {}).items()}})
            for key, demo in zip(keys, demos):
                group = data.create_group(key)
                group.attrs["num_samples"] = demo.num_samples
                group.attrs.update({name: _attr_value(value) for name, value in demo.attrs.items()})
                for name in PER_SAMPLE_DATASETS + ("skill_bounds", "final_state"):
                    group.create_dataset(name, data=getattr(demo, name))
                for obs_group in ("obs", "next_obs"):
                    sub = group.create_group(obs_group)
                    for name, value in getattr(demo, obs_group).items():
                        sub.create_dataset(name, data=value)
            mask = f.create_group("mask")
            mask.create_dataset("train", data=np.array(train, dtype="S"))
            mask.create_dataset("valid", data=np.array(valid, dtype="S"))

    return atomic_write(Path(path), write)


def _attr_value(value):
    """An hdf5 attribute value: dicts and lists as JSON text, None as "null", the rest as is."""
    if value is None or isinstance(value, (dict, list, tuple)):
        from tableclean_suite.environments.config import jsonable

        return json.dumps(jsonable(value))
    return value


#: Demo attributes stored as JSON text (decoded by [`read_demo`][tableclean_suite.demos.read_demo]).
JSON_DEMO_ATTRS = ("ep_meta", "plan")


def read_env_args(path) -> dict:
    """``data.attrs["env_args"]`` of the dataset at ``path``, decoded."""
    import h5py

    with h5py.File(path, "r") as f:
        return json.loads(f["data"].attrs["env_args"])


def demo_keys(path) -> list[str]:
    """The demo groups of ``path`` in numeric order (``demo_0``, ``demo_1``, ...)."""
    import h5py

    with h5py.File(path, "r") as f:
        return sorted(f["data"].keys(), key=lambda k: int(k.split("_")[-1]))


def read_demo(path, key: str = "demo_0") -> Demo:
    """The demo ``key`` of the dataset at ``path`` (``KeyError`` naming the demos there)."""
    import h5py

    with h5py.File(path, "r") as f:
        data = f["data"]
        if key not in data:
            raise KeyError(f"no demo {key!r} in {path}; demos: {', '.join(sorted(data.keys()))}")
        group = data[key]
        attrs = {}
        for name, value in group.attrs.items():
            attrs[name] = json.loads(value) if name in JSON_DEMO_ATTRS else (value.item() if isinstance(value, np.generic) else value)
        arrays = {name: group[name][()] for name in PER_SAMPLE_DATASETS + ("skill_bounds", "final_state")}
        obs = {name: group["obs"][name][()] for name in group["obs"]}
        next_obs = {name: group["next_obs"][name][()] for name in group["next_obs"]}
    return Demo(obs=obs, next_obs=next_obs, attrs=attrs, **arrays)


__all__ = [
    "ACTION_DIM", "Demo", "ENV_NAME", "EpisodeRecorder", "NO_TASK_STATE", "OBS_KEYS", "ROBOSUITE_ENV_TYPE",
    "VALID_FRACTION", "demo_keys", "env_args_of", "make_env_from_args", "read_demo", "read_env_args",
    "recording_controller", "split_keys", "write_dataset",
]
