"""env.step rate of TableClean against robosuite's Lift: the ``environment`` section of
``tableclean-bench speed`` (:mod:`.speed`; ``python -m benchmarks.env_speed`` is its alias).

Both environments use the same robot (Panda), the same default controller, the same control
frequency and no renderers, and run in the same process.  Timing blocks alternate between the
environments (Lift, TableClean, TableClean-pressing, Lift, ...) so that load from other processes
on the machine hits all of them alike; the reported ratio is TableClean rate / Lift rate (goal >= 0.9).

"TableClean (pressing)" keeps the sponge resting on segment 2 so that the per-substep wiping
check runs its full path (contact found + footprint test) at every substep.
"""

from __future__ import annotations

import time

import numpy as np

import tableclean_suite  # noqa: F401  (registers TableClean when robosuite is imported)

ROBOT = "Panda"
#: Goal: TableClean's env.step rate at least this fraction of Lift's.
RATIO_GOAL = 0.9
#: Defaults of the section: timed steps per environment, alternating blocks, control frequency (Hz).
DEFAULT_STEPS, DEFAULT_ROUNDS, DEFAULT_CONTROL_FREQ = 1000, 10, 20
#: Uniform random actions are drawn in +-ACTION_SCALE (OSC delta units) so the arm stays near its start.
ACTION_SCALE = 0.3
#: 0-based index of the segment the pressing benchmark rests the sponge on (segment 2).
PRESS_SEGMENT = 1


def make_env(name: str, control_freq: int, seed: int, **kwargs):
    """An environment with the shared benchmark settings (no rendering, no camera observations)."""
    import robosuite
    from robosuite.controllers import load_composite_controller_config

    return robosuite.make(
        name,
        robots=ROBOT,
        controller_configs=load_composite_controller_config(robot=ROBOT),
        has_renderer=False,
        has_offscreen_renderer=False,
        use_camera_obs=False,
        control_freq=control_freq,
        ignore_done=True,
        seed=seed,
        **kwargs,
    )


def press_sponge(env) -> None:
    """Rest the sponge on segment 2's centre (bottom on the table top), at rest."""
    center = env.geometry.segment_centers[PRESS_SEGMENT]
    pos = center + np.array([0.0, 0.0, env.task_config["sponge_half_size"][2]])
    env.sim.data.set_joint_qpos(env.sponge.joints[0], np.concatenate([pos, [1.0, 0.0, 0.0, 0.0]]))
    env.sim.data.set_joint_qvel(env.sponge.joints[0], np.zeros(6))
    env.sim.forward()


def time_block(env, actions: np.ndarray, before_step=None) -> float:
    """Seconds spent in ``env.step`` over ``actions`` (``before_step(env)`` runs untimed before each step)."""
    total = 0.0
    for action in actions:
        if before_step is not None:
            before_step(env)
        start = time.perf_counter()
        env.step(action)
        total += time.perf_counter() - start
    return total


def measure(steps: int, rounds: int, control_freq: int, seed: int) -> dict[str, float]:
    """Steps per second of each environment, from ``rounds`` alternating blocks of ``steps // rounds`` steps.

    Raises:
        ValueError: ``rounds`` or ``control_freq`` below 1, or ``steps`` below ``rounds`` (a block of no step).
    """
    if rounds < 1 or control_freq < 1 or steps < rounds:
        raise ValueError(f"need rounds >= 1, control_freq >= 1 and steps >= rounds; got steps={steps}, "
                         f"rounds={rounds}, control_freq={control_freq}")
    envs = {
        "Lift": make_env("Lift", control_freq, seed),
        "TableClean": make_env("TableClean", control_freq, seed, object_segment=1, arm_segment=1),
        "TableClean (pressing)": make_env("TableClean", control_freq, seed, object_segment=1, arm_segment=1),
    }
    hooks = {"TableClean (pressing)": press_sponge}
    rng = np.random.default_rng(seed)
    block = steps // rounds
    seconds = dict.fromkeys(envs, 0.0)
    for env in envs.values():
        env.reset()
    for _ in range(rounds):
        for name, env in envs.items():
            actions = rng.uniform(-ACTION_SCALE, ACTION_SCALE, size=(block, env.action_dim))
            seconds[name] += time_block(env, actions, hooks.get(name))
    for env in envs.values():
        env.close()
    return {name: block * rounds / total for name, total in seconds.items()}


def rate_ratio(rates: dict[str, float]) -> float:
    """TableClean's env.step rate over Lift's."""
    return rates["TableClean"] / rates["Lift"]


def report_lines(rates: dict[str, float]) -> list[str]:
    """The printed table: steps per second of each environment and its ratio to Lift's."""
    lift = rates["Lift"]
    lines = [f"{'environment':<24}{'steps/s':>10}{'ratio vs Lift':>16}"]
    lines += [f"{name:<24}{rate:>10.1f}{rate / lift:>16.3f}" for name, rate in rates.items()]
    lines.append(f"TableClean / Lift env.step rate ratio: {rate_ratio(rates):.3f} (goal >= {RATIO_GOAL:g})")
    return lines
