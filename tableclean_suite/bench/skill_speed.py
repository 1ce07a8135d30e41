"""Control steps and wall time of the skills in physics: the ``skills`` section of
``tableclean-bench speed`` (:mod:`.speed`; ``python -m benchmarks.skill_speed`` is its alias).

Runs the task model's optimal plan from a start layout (default: the paper's layout, object and
arm over segment 1, whose optimal plan is the 8-action sequence of Sec. 2) for ``--episodes``
episodes and prints

- per skill: executions, mean control steps, mean wall seconds, failures;
- per episode: control steps, wall seconds, and whether it reached the terminal state;
- the executor overhead: wall time the SkillController spends outside ``env.step`` (skill logic,
  ``skill_info()`` reads, the abstraction before and after each action) divided by the time
  spent inside ``env.step``, measured in the same run (goal <= 5%).  On the fast path "inside
  ``env.step``" is the stepper's ``step`` and its compiled phase loop (a fixed-waypoint phase's
  further control steps, physics plus the skill's compiled per-step checks).  The states the
  raw-MuJoCo replay needs are logged by the stepper (:class:`~tableclean_suite.controllers.fast_control.ControlStepLog`,
  five mjData arrays copied per control step, inside the timed step); an ``on_step`` callback
  would have charged that bench instrumentation to the executor's overhead;
- the control paths compared in the same run, episode by episode alternating: control steps/s
  of robosuite's ``env.step`` path, of the fast path (``make_skill_env(fast_control=True)``,
  :class:`~tableclean_suite.controllers.fast_control.FastSkillStepper`) and of raw MuJoCo (the
  fast path's recorded states, 25 ``mj_step`` per control step, nothing else), their ratios,
  and seconds per optimal episode on each path.

The tables above the comparison are those of the default (fast) path.

Goals (issue 4, section 5): optimal episode <= 4 s on a 2-core machine; overhead <= 5%.
Goals (issue 16): the fast path >= 5x robosuite's control steps/s and >= 0.8 of raw MuJoCo's.
"""

from __future__ import annotations

import time
from collections import defaultdict

import mujoco
import numpy as np

from tableclean_suite.bench.goal_text import against_goal
from tableclean_suite.controllers import SkillController, make_skill_env
from tableclean_suite.controllers.fast_control import LOG_FIELDS, ControlStepLog, fast_stepper_of
from tableclean_suite.robosuite_adapter import mj_model

#: Goal for one optimal episode's wall time (s).
EPISODE_GOAL_S = 4.0
#: Goal for the executor's overhead over raw env.step.
OVERHEAD_GOAL = 0.05
#: Goal for the fast path's control steps/s over robosuite's env.step path (issue 16; was 3x in issue 9).
FAST_SPEEDUP_GOAL = 5.0
#: Goal for the fast path's control steps/s over raw MuJoCo's (25 mj_step per control step, issue 16).
RAW_MUJOCO_GOAL = 0.8
#: mjData fields a raw-MuJoCo replay restores before each control step's substeps.
REPLAY_FIELDS = LOG_FIELDS


def run(episodes: int, layout=(1, 1), seed: int = 0, fast_control: bool = True, task=None) -> dict:
    """Run ``episodes`` optimal episodes on one control path; returns per-episode and per-action records.

    Returns a dict with ``"episodes"``: list of dicts (steps, wall_s, env_s, terminal, failures)
    and ``"actions"``: list of dicts (action, steps, wall_s, env_s, success).
    """
    env = make_skill_env(*layout, seed=seed, hard_reset=False, fast_control=fast_control, task=task)
    records = _empty_records()
    for _ in range(episodes):
        _run_episode(env, records)
    env.close()
    return records


def warm_up(layout=(1, 1), seed: int = 0, task=None) -> None:
    """One untimed optimal episode on a throwaway fast-path env: the compiled kernels both paths call (the fast
    path's, the env's contact and wiping kernels) are loaded from numba's cache, or compiled when it is cold
    (~20-25 s in a fresh checkout or snapshot), before anything is timed.  The timed envs are other instances,
    so their episodes (and control steps) are those of a run without it."""
    env = make_skill_env(*layout, seed=seed, hard_reset=False, fast_control=True, task=task)
    try:
        _run_episode(env, _empty_records(), record_states=fast_stepper_of(env) is not None)
    finally:
        env.close()


def compare_paths(episodes: int, layout=(1, 1), seed: int = 0, task=None, warm: bool = True) -> dict:
    """Optimal episodes on robosuite's path and the fast path, alternating, plus raw MuJoCo on the fast path's states.

    Returns ``{"robosuite": records, "fast": records, "mujoco": {"steps", "seconds", "substeps"}}``
    with records as :func:`run`'s; the raw-MuJoCo entry counts control steps of ``substeps``
    ``mj_step`` calls each (``control_timestep / model_timestep``: 25) and the seconds spent in them.
    ``warm``: run :func:`warm_up` first (otherwise a cold numba cache puts its compile time into the
    first fast episode's ``env.step`` time).
    """
    if warm:
        warm_up(layout, seed, task)
    envs = {path: make_skill_env(*layout, seed=seed, hard_reset=False, fast_control=path == "fast", task=task)
            for path in ("robosuite", "fast")}
    records = {path: _empty_records() for path in envs}
    fast_env = envs["fast"]
    mujoco_time = {"steps": 0, "seconds": 0.0, "substeps": int(fast_env.control_timestep / fast_env.model_timestep)}
    for _ in range(episodes):
        _run_episode(envs["robosuite"], records["robosuite"])
        states = _run_episode(envs["fast"], records["fast"], record_states=True)
        steps, seconds = _replay_mujoco(envs["fast"], states)
        mujoco_time["steps"] += steps
        mujoco_time["seconds"] += seconds
    for env in envs.values():
        env.close()
    return {**records, "mujoco": mujoco_time}


def _empty_records() -> dict:
    return {"episodes": [], "actions": []}


def _run_episode(env, records: dict, record_states: bool = False) -> list[dict]:
    """Reset ``env``, execute the optimal plan, append its rows to ``records``.

    Returns the mjData fields of :data:`REPLAY_FIELDS` at the start of every control step when
    ``record_states`` (for :func:`_replay_mujoco`; needs ``env``'s fast stepper, which logs them),
    else an empty list.
    """
    model = env.task_model
    stepper = fast_stepper_of(env)
    if record_states:
        if stepper is None:
            raise ValueError("recording the control steps' states needs a fast stepper (make_skill_env(fast_control=True))")
        stepper.state_log = ControlStepLog(stepper)
    controller = SkillController(env, model)
    env.reset()
    plan = model.shortest_plan(env.symbolic_state())
    start = time.perf_counter()
    results = controller.execute_plan(plan)
    wall = time.perf_counter() - start
    for r in results:
        records["actions"].append(
            dict(action=model.action_name(r.action), steps=r.steps, wall_s=r.wall_time, env_s=r.env_time, success=r.success)
        )
    final = results[-1].state_after if results else None
    records["episodes"].append(
        dict(
            actions=len(results),
            steps=sum(r.steps for r in results),
            wall_s=wall,
            env_s=sum(r.env_time for r in results),
            terminal=bool(final is not None and final.is_terminal),
            failures=sum(not r.success for r in results),
        )
    )
    if not record_states:
        return []
    states, stepper.state_log = stepper.state_log.states(), None
    return states


def _replay_mujoco(env, states: list[dict]) -> tuple[int, float]:
    """(control steps, seconds): raw ``mj_step`` substeps from each recorded state, on a copy of the data."""
    model = mj_model(env.sim)
    data = mujoco.MjData(model)
    substeps = int(env.control_timestep / env.model_timestep)
    seconds = 0.0
    for state in states:
        for field, value in state.items():
            getattr(data, field)[:] = value
        start = time.perf_counter()
        for _ in range(substeps):
            mujoco.mj_step(model, data)
        seconds += time.perf_counter() - start
    return len(states), seconds


def overhead_against_goal(overhead: float) -> str:
    """The executor's overhead (a fraction) against :data:`OVERHEAD_GOAL`, distance in percentage points."""
    return against_goal(f"{overhead:.2%}", overhead, OVERHEAD_GOAL, f"{OVERHEAD_GOAL:.0%}", True,
                        f"{100 * abs(overhead - OVERHEAD_GOAL):.2f} points")


def speedup_against_goal(speedup: float) -> str:
    """The fast path's control steps/s over robosuite's against :data:`FAST_SPEEDUP_GOAL`."""
    return against_goal(f"{speedup:.2f}x", speedup, FAST_SPEEDUP_GOAL, f"{FAST_SPEEDUP_GOAL:g}x", False,
                        f"{abs(speedup - FAST_SPEEDUP_GOAL):.3f}")


def raw_ratio_against_goal(ratio: float) -> str:
    """The fast path's control steps/s over raw MuJoCo's against :data:`RAW_MUJOCO_GOAL`."""
    return against_goal(f"{ratio:.2f}", ratio, RAW_MUJOCO_GOAL, f"{RAW_MUJOCO_GOAL:g}", False,
                        f"{abs(ratio - RAW_MUJOCO_GOAL):.3f}")


def format_comparison(comparison: dict) -> str:
    """The control-path table (plain text) of :func:`compare_paths`'s records."""
    rates, episode_s = {}, {}
    for path in ("robosuite", "fast"):
        episodes = comparison[path]["episodes"]
        steps = sum(ep["steps"] for ep in episodes)
        rates[path] = steps / max(sum(ep["env_s"] for ep in episodes), np.finfo(float).tiny)
        episode_s[path] = float(np.mean([ep["wall_s"] for ep in episodes]))
    raw = comparison["mujoco"]
    rates["raw MuJoCo"] = raw["steps"] / max(raw["seconds"], np.finfo(float).tiny)
    n = len(comparison["fast"]["episodes"])
    lines = [
        f"control paths (same run, alternating episode by episode; {n} optimal episode(s) each)",
        f"{'path':12s} {'steps/s':>8s} {'ms/step':>8s} {'s/episode':>10s}",
    ]
    for path, rate in rates.items():
        seconds = f"{episode_s[path]:10.2f}" if path in episode_s else f"{'-':>10s}"
        lines.append(f"{path:12s} {rate:8.0f} {1000 / rate:8.3f} {seconds}")
    speedup = rates["fast"] / rates["robosuite"]
    raw_ratio = rates["fast"] / rates["raw MuJoCo"]
    lines += [
        f"fast / robosuite: {speedup:.2f}x (goal >= {FAST_SPEEDUP_GOAL:.0f}x: {'met' if speedup >= FAST_SPEEDUP_GOAL else 'NOT met'})",
        f"fast / raw MuJoCo: {raw_ratio:.2f} (goal >= {RAW_MUJOCO_GOAL:g}: {'met' if raw_ratio >= RAW_MUJOCO_GOAL else 'NOT met'}) "
        f"(robosuite / raw MuJoCo: {rates['robosuite'] / rates['raw MuJoCo']:.2f}); "
        f"raw MuJoCo = {raw['substeps']} mj_step per control step from the fast path's states",
    ]
    return "\n".join(lines)


def format_report(records: dict) -> str:
    """The printed tables (plain text) of :func:`run`'s records."""
    lines = ["per skill", f"{'skill':8s} {'runs':>5s} {'steps':>7s} {'wall s':>8s} {'env s':>8s} {'failed':>6s}"]
    by_action = defaultdict(list)
    for row in records["actions"]:
        by_action[row["action"]].append(row)
    for action, rows in by_action.items():
        lines.append(
            f"{action:8s} {len(rows):5d} {np.mean([r['steps'] for r in rows]):7.1f} "
            f"{np.mean([r['wall_s'] for r in rows]):8.3f} {np.mean([r['env_s'] for r in rows]):8.3f} "
            f"{sum(not r['success'] for r in rows):6d}"
        )
    episodes = records["episodes"]
    header = f"{'episode':>7s} {'actions':>7s} {'steps':>6s} {'wall s':>7s} {'terminal':>8s}"
    lines += ["", "per optimal episode", header]
    for k, ep in enumerate(episodes):
        lines.append(f"{k:7d} {ep['actions']:7d} {ep['steps']:6d} {ep['wall_s']:7.2f} {str(ep['terminal']):>8s}")
    wall = np.array([ep["wall_s"] for ep in episodes])
    env_s = sum(ep["env_s"] for ep in episodes)
    overhead = (wall.sum() - env_s) / env_s if env_s > 0 else float("nan")
    lines += [
        "",
        f"episode wall time: mean {wall.mean():.2f} s, max {wall.max():.2f} s (goal <= {EPISODE_GOAL_S:.0f} s)",
        f"episode steps: mean {np.mean([ep['steps'] for ep in episodes]):.0f}; "
        f"env.step: {1000 * env_s / max(1, sum(ep['steps'] for ep in episodes)):.2f} ms per control step",
        f"executor overhead over env.step: {overhead:.2%} (goal <= {OVERHEAD_GOAL:.0%})",
        f"episodes reaching the terminal state: {sum(ep['terminal'] for ep in episodes)}/{len(episodes)}",
    ]
    return "\n".join(lines)


def goal_numbers(comparison: dict) -> dict[str, float]:
    """The goals' measurements of :func:`compare_paths`' records: ``episode_s`` (mean wall seconds of
    an optimal episode on the fast path), ``overhead`` (the executor's time outside ``env.step``
    over its time inside, fast path), ``speedup`` (fast path's control steps/s over robosuite's) and
    ``raw_ratio`` (fast path's control steps/s over raw MuJoCo's)."""
    fast = comparison["fast"]["episodes"]
    wall = sum(ep["wall_s"] for ep in fast)
    env_s = sum(ep["env_s"] for ep in fast)
    rates = {}
    for path in ("robosuite", "fast"):
        episodes = comparison[path]["episodes"]
        rates[path] = sum(ep["steps"] for ep in episodes) / max(sum(ep["env_s"] for ep in episodes),
                                                                np.finfo(float).tiny)
    return {"episode_s": wall / len(fast),
            "overhead": (wall - env_s) / env_s if env_s > 0 else float("nan"),
            "speedup": rates["fast"] / rates["robosuite"],
            "raw_ratio": rates["fast"] / (comparison["mujoco"]["steps"] / max(comparison["mujoco"]["seconds"],
                                                                              np.finfo(float).tiny))}
