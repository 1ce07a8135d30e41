"""Add an action from outside the package: MOVE_BACK (the arm goes to the previous segment).

Registers the action, builds a three-segment task with it, and compares learning with and
without it on ``three_segments`` (Q-learning and SARSA, reward r4, the paper's alpha = gamma
= 0.3, epsilon = 0.1):

    python examples/move_back.py                 # 1000 runs x 12000 iterations, ~6 s
    python examples/move_back.py --runs 100 --json

Nothing in the package is edited: the action is data (a name and a pure effect), and the
model, the learners, the exact analysis and the Gym envs size themselves from the spec.
"""

from __future__ import annotations

import argparse
import json
import sys

from tableclean_suite.analysis import exact_success_probability
from tableclean_suite.learners import train
from tableclean_suite.curves import learning_curves
from tableclean_suite.metrics import iterations_to_max_success, plateau
from tableclean_suite.task import ActionRule, Outcome, TaskModel, TaskState, register_action

#: The paper's hyperparameters.
ALPHA = GAMMA = 0.3
EPSILON = 0.1
MAX_ITR = 500
REWARD = "r4"
LEARNERS = ("q_learning", "sarsa")


def move_back(state: TaskState) -> tuple[TaskState, Outcome]:
    """MOVE_BACK: the arm goes to the previous segment, k -> k - 1 (1 -> N); a held object goes along."""
    return state.replace(arm=(state.arm - 1) % state.n_segments), Outcome.ROUTINE


def tasks() -> dict[str, TaskModel]:
    """``three_segments`` as shipped, and the same task with MOVE_BACK after MOVE."""
    register_action(ActionRule("move_back", move_back, "the arm goes to the previous segment"), overwrite=True)
    base = TaskModel(spec="three_segments")
    with_back = base.spec.replace(name="three_segments_move_back",
                                  actions=("move", "move_back", "pick", "place", "clean"))
    return {"three_segments": base, "three_segments_move_back": TaskModel(spec=with_back)}


def optimal_policy(model: TaskModel):
    """Greedy action per state code that follows a shortest plan (first such action in the spec's order)."""
    import numpy as np

    distance = model.shortest_plan_lengths(model.all_states())
    policy = np.zeros(model.n_states, dtype=np.int64)
    for state in model.all_states():
        if state.is_terminal or distance[state.index] is None:
            continue
        for action in range(model.n_actions):
            nxt, _ = model.step(state, action)
            if distance.get(nxt.index) == distance[state.index] - 1:
                policy[state.index] = action
                break
    return policy


def compare(runs: int, iterations: int, seed: int) -> list[dict]:
    """One row per (task, learner): sizes, the optimal plan, and what the learner reached."""
    rows = []
    for name, model in tasks().items():
        exact = float(exact_success_probability(optimal_policy(model), EPSILON, MAX_ITR, model=model))
        for learner in LEARNERS:
            result = train(learner, REWARD, runs=runs, iterations=iterations, alpha=ALPHA, gamma=GAMMA,
                           epsilon=EPSILON, max_itr=MAX_ITR, seed=seed, task=model)
            success = learning_curves(result)["success"]
            rows.append({
                "task": name,
                "actions": model.n_actions,
                "reachable_states": len(model.reachable_states()),
                "plan_length": len(model.shortest_plan(model.start_state)),
                "optimal_success_exact": round(exact, 4),
                "learner": learner,
                "max_success_iterations": iterations_to_max_success(success),
                "success_plateau": round(plateau(success), 4),
            })
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python examples/move_back.py", description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=1000, help="independent runs per learner (>= 1)")
    parser.add_argument("--iterations", type=int, default=12000, help="environment steps per run (>= 1)")
    parser.add_argument("--seed", type=int, default=0, help="base seed (>= 0)")
    parser.add_argument("--json", action="store_true", help="print the rows as JSON instead of a table")
    args = parser.parse_args(argv)
    for flag, value, low in (("--runs", args.runs, 1), ("--iterations", args.iterations, 1), ("--seed", args.seed, 0)):
        if value < low:
            parser.error(f"{flag} must be >= {low}, got {value}")
    rows = compare(args.runs, args.iterations, args.seed)
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    import pandas as pd

    print(f"{REWARD}, alpha = gamma = {ALPHA}, epsilon = {EPSILON}, {args.runs} runs x {args.iterations} iterations")
    print(pd.DataFrame(rows).to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
