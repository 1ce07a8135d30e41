"""Add an object type from outside the package and run the optimal plan with it in physics.

Registers ``flat_box`` (a 6 x 4 x 3 cm wooden box: its fingers must close across the 4 cm side),
builds a three-segment task with a cube and the flat box, and executes the task model's
shortest plan from the start with the skills in MuJoCo:

    python examples/custom_object.py            # ~10 s
    python examples/custom_object.py --json

Nothing in the package is edited: registering an object type is one line (how to build it);
its grasp, footprint and resting height are read from its collision geometry in MuJoCo.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

from robosuite.models.objects import BoxObject  # noqa: E402

from tableclean_suite.environments import ObjectType, register_object  # noqa: E402
from tableclean_suite.task import TaskModel, TaskSpec  # noqa: E402

#: Half extents of the flat box [m] (x, y, z): 6 x 4 x 3 cm.
FLAT_BOX_HALF_SIZE = (0.03, 0.02, 0.015)
#: Its colour (RGBA): green.
FLAT_BOX_RGBA = (0.15, 0.6, 0.25, 1.0)


def flat_box(name: str) -> BoxObject:
    """The robosuite object of the ``flat_box`` type named ``name``."""
    return BoxObject(name=name, size=list(FLAT_BOX_HALF_SIZE), rgba=list(FLAT_BOX_RGBA))


def register() -> ObjectType:
    """Register ``flat_box``; the skills close the fingers across its 4 cm side (read from its geometry)."""
    return register_object("flat_box", flat_box, description="a flat 6 x 4 x 3 cm box (examples/custom_object.py)",
                           overwrite=True)


def spec() -> TaskSpec:
    """Three segments, a cube and the flat box, both starting on segment 1."""
    return TaskSpec("three_segments_flat_box", segments=3, objects=("box", "flat_box"),
                    description="examples/custom_object.py")


def run(seed: int) -> list[dict]:
    """Execute the shortest plan from the spec's start in physics; one row per action."""
    from tableclean_suite.controllers import SkillController, make_skill_env

    register()
    model = TaskModel(spec=spec())
    env = make_skill_env(task=model.spec, seed=seed)
    try:
        env.reset()
        controller = SkillController(env, model)
        rows = []
        for result in controller.execute_plan(model.shortest_plan(env.symbolic_state())):
            rows.append({
                "action": model.action_name(result.action), "success": result.success, "steps": result.steps,
                "state_after": None if result.state_after is None else result.state_after.name, "reason": result.reason,
            })
        return rows
    finally:
        env.close()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python examples/custom_object.py", description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0, help="placement seed (>= 0)")
    parser.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = parser.parse_args(argv)
    if args.seed < 0:
        parser.error(f"--seed must be >= 0, got {args.seed}")
    rows = run(args.seed)
    ok = bool(rows) and all(r["success"] for r in rows) and rows[-1]["state_after"] is not None \
        and "unclean" not in rows[-1]["state_after"]
    if args.json:
        print(json.dumps({"rows": rows, "terminal": ok}, indent=1))
    else:
        for r in rows:
            print(f"{r['action']:>6}: {'ok' if r['success'] else 'FAILED'} in {r['steps']:4d} control steps -> {r['state_after']}")
        print(f"{'reached the terminal state' if ok else 'did NOT reach the terminal state'} in "
              f"{sum(r['steps'] for r in rows)} control steps")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
