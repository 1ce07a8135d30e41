"""``python -m benchmarks.skill_speed``: control steps and wall time of the skills in physics.

Runs the task model's optimal plan from a start layout (default: the paper's layout, object and
arm over segment 1, whose optimal plan is the 8-action sequence of Sec. 2) for ``--episodes``
episodes and prints

- per skill: executions, mean control steps, mean wall seconds, failures;
- per episode: control steps, wall seconds, and whether it reached the terminal state;
- the executor overhead: wall time the SkillController spends outside ``env.step`` (skill logic,
  ``skill_info()`` reads, the abstraction before and after each action) divided by the time
  spent inside ``env.step``, measured in the same run (goal <= 5%).

Goals (issue 4, section 5): optimal episode <= 4 s on a 2-core machine; overhead <= 5%.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import defaultdict

import numpy as np

from tableclean_suite.bench.cli import positive_int
from tableclean_suite.controllers import SkillController, make_skill_env
from tableclean_suite.task import Action, TaskModel

#: Goal for one optimal episode's wall time (s).
EPISODE_GOAL_S = 4.0
#: Goal for the executor's overhead over raw env.step.
OVERHEAD_GOAL = 0.05


def parse_args(argv=None) -> argparse.Namespace:
    """Command-line options; argparse exits with a clear message on bad flags."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.skill_speed", description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=positive_int, default=3, help="optimal episodes to run (default 3)")
    parser.add_argument(
        "--layout", type=int, nargs=2, metavar=("OBJECT_SEGMENT", "ARM_SEGMENT"), default=(1, 1),
        choices=(1, 2), help="start layout, 1-based segments (default: 1 1, the paper's layout)",
    )
    parser.add_argument("--seed", type=int, default=0, help="environment seed (default 0)")
    return parser.parse_args(argv)


def run(episodes: int, layout=(1, 1), seed: int = 0) -> dict:
    """Run ``episodes`` optimal episodes; returns per-episode and per-action records.

    Returns a dict with ``"episodes"``: list of dicts (steps, wall_s, env_s, terminal, failures)
    and ``"actions"``: list of dicts (action, steps, wall_s, env_s, success).
    """
    env = make_skill_env(*layout, seed=seed, hard_reset=False)
    model = TaskModel()
    controller = SkillController(env, model)
    episode_rows, action_rows = [], []
    for _ in range(episodes):
        env.reset()
        plan = model.shortest_plan(env.symbolic_state())
        start = time.perf_counter()
        results = controller.execute_plan(plan)
        wall = time.perf_counter() - start
        for r in results:
            action_rows.append(
                dict(action=r.action, steps=r.steps, wall_s=r.wall_time, env_s=r.env_time, success=r.success)
            )
        final = results[-1].state_after if results else None
        episode_rows.append(
            dict(
                actions=len(results),
                steps=sum(r.steps for r in results),
                wall_s=wall,
                env_s=sum(r.env_time for r in results),
                terminal=bool(final is not None and final.is_terminal),
                failures=sum(not r.success for r in results),
            )
        )
    env.close()
    return {"episodes": episode_rows, "actions": action_rows}


def format_report(records: dict) -> str:
    """The printed tables (plain text) of :func:`run`'s records."""
    lines = ["per skill", f"{'skill':8s} {'runs':>5s} {'steps':>7s} {'wall s':>8s} {'env s':>8s} {'failed':>6s}"]
    by_action = defaultdict(list)
    for row in records["actions"]:
        by_action[row["action"]].append(row)
    for action in Action:
        rows = by_action.get(action)
        if not rows:
            continue
        lines.append(
            f"{action.name.lower():8s} {len(rows):5d} {np.mean([r['steps'] for r in rows]):7.1f} "
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


def main(argv=None) -> int:
    args = parse_args(argv)
    records = run(args.episodes, tuple(args.layout), args.seed)
    print(format_report(records))
    return 0 if all(ep["terminal"] for ep in records["episodes"]) else 1


if __name__ == "__main__":
    sys.exit(main())
