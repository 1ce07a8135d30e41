"""The scaling study's families of task specs, their exact quantities and their training windows.

The product family (`family_spec`, `family_specs`): the paper's task grown to N segments x M
objects; its plans grow with the states.  The fixed-plan family (`fixed_plan_spec`): N = 3,
segments 1 and 2 unclean, object 1 and the arm on segment 1, objects 2..M parked on the clean
segment 3: an 8-step optimal plan for every M while the reachable states grow.  `describe_spec`
gives what the study needs of a spec; `describe_family` orders specs by states reachable from
the start, the study's measure of size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


#: The default family is the product DEFAULT_SEGMENTS x DEFAULT_OBJECT_COUNTS: segments N = 2..5 ...
DEFAULT_SEGMENTS = tuple(range(2, 6))
#: ... x objects M = 1..3 (12 specs, 20 .. 31 320 reachable states, 24 .. 34 560 codes).
DEFAULT_OBJECT_COUNTS = tuple(range(1, 4))

#: Iterations for the paper's spec (4x the paper's 3000: r1 and r4 approach their plateaus slowly on larger specs).
DEFAULT_BASE_WINDOW = 12000
#: Window growth with the optimal plan length: window = base * (L / L0) ** exponent.
DEFAULT_WINDOW_EXPONENT = 3.0
#: The paper's episode truncation (iterations), for the paper's spec; scaled linearly with L / L0.
BASE_MAX_ITR = 500
#: The paper's hyperparameters: learning rate, discount, exploration probability (all in [0, 1]).
ALPHA, PAPER_GAMMA, EPSILON = 0.3, 0.3, 0.1
#: Discounts the study trains at: the paper's and a long-horizon one (0.3**L vanishes for long plans).
DEFAULT_GAMMAS = (PAPER_GAMMA, 0.9)

#: The fixed-plan family's segments, its clean parking segment (0-based) and default object counts.
FIXED_PLAN_SEGMENTS = 3
FIXED_PLAN_PARKING = 2
DEFAULT_FIXED_PLAN_OBJECTS = tuple(range(1, 6))
#: Names of the two families (``SpecInfo.family``, ``scaling.csv``'s ``family`` column).
PRODUCT_FAMILY, FIXED_PLAN_FAMILY = "product", "fixed_plan"


@dataclass(frozen=True)
class SpecInfo:
    """One spec of the family and what the study needs of it.

    Attributes:
        family: `PRODUCT_FAMILY` or `FIXED_PLAN_FAMILY`.
        name: spec name (``scale_n{N}_m{M}``, ``paper`` for N = 2, M = 1; ``fixed_plan_m{M}``).
        segments, objects: N >= 2 and M >= 1.
        codes: state codes, ``2**N * (N + 1)**M * N``.
        reachable: states reachable from every all-unclean layout (terminal ones included).
        reachable_from_start: states reachable from the spec's start state (what training can visit;
            the study's measure of size).
        plan_length: optimal plan length (steps) from the default start.
        optimal_success: exact epsilon-greedy success probability of an optimal policy, in [0, 1].
        window: iterations per run (>= 1).
        max_itr: episode truncation (iterations, >= 1).
    """

    family: str
    name: str
    segments: int
    objects: int
    codes: int
    reachable: int
    reachable_from_start: int
    plan_length: int
    optimal_success: float
    window: int
    max_itr: int


def counts_text(values) -> str:
    """``(2, 3)`` -> ``"2,3"``: a list flag's values as they are typed."""
    return ",".join(str(v) for v in values)


def family_spec(segments: int, objects: int):
    """The family's spec with N ``segments`` and M ``objects`` boxes (the paper's for N=2, M=1)."""
    from tableclean_suite.task import TaskSpec, get_task_spec

    paper = get_task_spec("paper")
    if (segments, objects) == (paper.segments, paper.n_objects):
        return paper
    return TaskSpec(f"scale_n{segments}_m{objects}", segments=segments, objects=objects,
                    description=f"scaling study: {segments} segments, {objects} object(s)")


def family_specs(segments, objects) -> list:
    """The family's specs for every ``(N, M)`` in ``segments x objects`` (N >= 2, M >= 1), N-major."""
    return [family_spec(n, m) for n in segments for m in objects]


def fixed_plan_spec(objects: int):
    """The fixed-plan family's spec with M ``objects`` (module docstring): 8-step plan for any M."""
    from tableclean_suite.task import TaskSpec
    from tableclean_suite.task.state import TaskState

    clean = (False, False) + (True,) * (FIXED_PLAN_SEGMENTS - 2)
    start = TaskState(clean, (0,) + (FIXED_PLAN_PARKING,) * (objects - 1), 0)
    return TaskSpec(f"fixed_plan_m{objects}", segments=FIXED_PLAN_SEGMENTS, objects=objects, start_state=start,
                    description=f"scaling study, fixed plan: {objects - 1} object(s) parked on the clean segment")


def plan_window(plan_length: int, paper_plan_length: int, base_window: int, exponent: float) -> tuple[int, int]:
    """``(window, max_itr)`` in iterations for a spec whose optimal plan has ``plan_length`` steps.

    ``window = base_window * (L / L0) ** exponent`` and ``max_itr = BASE_MAX_ITR * L / L0``,
    both rounded up (L0 = ``paper_plan_length``).
    """
    ratio = plan_length / paper_plan_length
    return math.ceil(base_window * ratio ** exponent), math.ceil(BASE_MAX_ITR * ratio)


def paper_plan_steps() -> int:
    """L0: the paper spec's optimal plan length from its default start (the model's own BFS)."""
    from tableclean_suite.task import TaskModel

    model = TaskModel(spec="paper")
    return len(model.shortest_plan(model.start_state))


def describe_spec(spec, paper_plan_length: int, base_window: int, exponent: float, family: str = PRODUCT_FAMILY):
    """``(SpecInfo, TaskModel)`` of ``spec``: sizes, optimal plan and its exact success, window."""
    from tableclean_suite.analysis import exact_success_probability
    from tableclean_suite.task import TaskModel

    model = TaskModel(spec=spec)
    plan_length = int(model.distances_to_terminal()[model.start_state.index])
    window, max_itr = plan_window(plan_length, paper_plan_length, base_window, exponent)
    success = float(exact_success_probability(model.optimal_policy(), EPSILON, max_itr, model=model))
    info = SpecInfo(family, spec.name, spec.segments, spec.n_objects, model.n_states, len(model.reachable_states()),
                    len(model.reachable_states([model.start_state])), plan_length, success, window, max_itr)
    return info, model


def describe_family(specs, paper_plan_length: int, base_window: int, exponent: float,
                    family: str = PRODUCT_FAMILY) -> list:
    """[`describe_spec`][tableclean_suite.bench.scaling.family.describe_spec] of every spec, as
    ``[(SpecInfo, TaskModel)]`` ordered by states reachable from the start (ties by N, then M)."""
    described = [describe_spec(s, paper_plan_length, base_window, exponent, family) for s in specs]
    return sorted(described, key=lambda pair: (pair[0].reachable_from_start, pair[0].segments, pair[0].objects))
