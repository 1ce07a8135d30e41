"""MOVE_BACK in physics: a user action gets its skill from outside the package.

``examples/move_back.py`` adds the action MOVE_BACK (the arm goes to the previous segment)
symbolically.  Here it also gets a skill: :class:`MoveBackSkill` reuses the built-in move skill
with the other destination and is registered with ``register_skill``.  The script then runs the
shortest plan of ``three_segments`` with MOVE_BACK from a start where going back is shorter,
in MuJoCo:

    python examples/move_back_physics.py        # ~10 s
    python examples/move_back_physics.py --json

Nothing in the package is edited.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

from tableclean_suite.controllers import MoveSkill, register_skill  # noqa: E402
from tableclean_suite.task import ActionRule, Outcome, TaskModel, TaskState, register_action  # noqa: E402

#: Where the plan starts: the object on segment 3 and the arm over segment 1 (0-based 2 and 0).
START = TaskState((False, False, False), (2,), 0)


def move_back(state: TaskState) -> tuple[TaskState, Outcome]:
    """MOVE_BACK: the arm goes to the previous segment, k -> k - 1 (1 -> N); a held object goes along."""
    return state.replace(arm=(state.arm - 1) % state.n_segments), Outcome.ROUTINE


class MoveBackSkill(MoveSkill):
    """The move skill towards the previous segment."""

    action = "move_back"

    def target_segment(self) -> int:
        return (self.state.arm - 1) % self.state.n_segments


def model() -> TaskModel:
    """``three_segments`` with MOVE_BACK after MOVE (action and skill registered)."""
    register_action(ActionRule("move_back", move_back, "the arm goes to the previous segment"), overwrite=True)
    register_skill("move_back", MoveBackSkill, replace=True)
    base = TaskModel(spec="three_segments")
    return TaskModel(spec=base.spec.replace(name="three_segments_move_back",
                                            actions=("move", "move_back", "pick", "place", "clean")))


def run(seed: int) -> dict:
    """Execute the shortest plan from :data:`START` in physics; returns the rows and whether it ended terminal."""
    from tableclean_suite.controllers import SkillController, make_skill_env
    from tableclean_suite.physics_backend import stage

    task = model()
    plan = [task.action_name(a) for a in task.shortest_plan(START)]
    env = make_skill_env(task=task.spec, seed=seed)
    try:
        controller = SkillController(env, task)
        stage(env, controller, START, seed=seed)
        results = controller.execute_plan(plan)
        rows = [{"action": task.action_name(r.action), "success": r.success, "steps": r.steps,
                 "state_after": None if r.state_after is None else r.state_after.name,
                 "matches_model": r.state_after == task.step(r.state_before, r.action)[0]} for r in results]
        terminal = bool(results) and results[-1].state_after is not None and results[-1].state_after.is_terminal
        return {"plan": plan, "rows": rows, "terminal": terminal}
    finally:
        env.close()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python examples/move_back_physics.py", description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="placement seed (>= 0)")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    args = parser.parse_args(argv)
    if args.seed < 0:
        parser.error(f"--seed must be >= 0, got {args.seed}")
    result = run(args.seed)
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        print(f"plan from {START.name}: {', '.join(result['plan'])}")
        for r in result["rows"]:
            print(f"{r['action']:>9}: {'ok' if r['success'] else 'FAILED'} in {r['steps']:4d} control steps -> {r['state_after']}")
        print("reached the terminal state" if result["terminal"] else "did NOT reach the terminal state")
    return 0 if result["terminal"] and all(r["success"] for r in result["rows"]) else 1


if __name__ == "__main__":
    sys.exit(main())
