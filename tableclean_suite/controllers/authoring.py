"""Write a skill as a short list of primitives whose targets are named by what they mean.

A new task-level action needs its symbolic rule (``TaskState -> (TaskState, Outcome)``) and a skill that
carries it out in MuJoCo: [`compose_skill`][tableclean_suite.controllers.authoring.compose_skill] makes the
skill from steps ([`reach`][tableclean_suite.controllers.authoring.reach],
[`grasp`][tableclean_suite.controllers.authoring.grasp], [`release`][tableclean_suite.controllers.authoring.release],
[`wipe`][tableclean_suite.controllers.authoring.wipe]) whose targets (objects, segments, spots) are read from the
scene when the skill runs, relative to the state it starts in.  Heights, depths and yaws come from the objects'
geometry ([`primitives`][tableclean_suite.controllers.primitives]); the documentation's "Write a skill" page
lists the steps and targets and shows a whole example.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from tableclean_suite.controllers.clean import WIPE_PHASES, wipe_plan
from tableclean_suite.controllers.configs import CleanConfig, ComposedConfig, checked_skill_config
from tableclean_suite.controllers.osc import GRIPPER_CLOSE, GRIPPER_OPEN
from tableclean_suite.controllers.place import gripper_of, place_spot
from tableclean_suite.controllers.primitives import Grasp, PrimitiveSkill, Reach, Release, object_body
from tableclean_suite.controllers.skill import SkillFailure
from tableclean_suite.environments.placement import footprint_of, free_spot as placement_free_spot, other_segments
from tableclean_suite.task import ActionRule, TaskState

Info = Mapping[str, Any]
#: Control steps a composed skill may use unless ``max_steps`` says otherwise (the clean skill's budget).
DEFAULT_MAX_STEPS = 900


class Context:
    """What the steps of one execution share: the start state and the object the skill holds (0-based or None)."""

    def __init__(self, state: TaskState):
        self.state = state
        self.held: int | None = state.held_object


# -- targets ------------------------------------------------------------------------------------
Segment = Callable[[Context], int]
Object = Callable[[Context], int]
Spot = Callable[[Context, Any, Info], np.ndarray]


def arm_segment() -> Segment:
    """The segment the arm is above when the skill starts (0-based)."""
    return lambda ctx: ctx.state.arm


def next_segment() -> Segment:
    """The segment after the arm's (k -> k + 1, N -> 1)."""
    return lambda ctx: (ctx.state.arm + 1) % ctx.state.n_segments


def previous_segment() -> Segment:
    """The segment before the arm's (k -> k - 1, 1 -> N)."""
    return lambda ctx: (ctx.state.arm - 1) % ctx.state.n_segments


def segment(number: int) -> Segment:
    """Segment ``number`` (1-based, as users count them)."""
    return lambda ctx: int(number) - 1


def lying_object(on: Segment | None = None) -> Object:
    """The lowest-numbered object lying on segment ``on`` (default the arm's) when the skill starts."""
    where = arm_segment() if on is None else on

    def resolve(ctx: Context) -> int:
        lying = ctx.state.objects_on(where(ctx))
        if not lying:
            raise SkillFailure(f"no object lies on segment {where(ctx) + 1}")
        return lying[0]
    return resolve


def held_object() -> Object:
    """The object held when the skill starts."""
    def resolve(ctx: Context) -> int:
        if ctx.state.held_object is None:
            raise SkillFailure("nothing is held")
        return ctx.state.held_object
    return resolve


def segment_center(which: Segment | None = None) -> Spot:
    """The centre (world xy, m) of segment ``which`` (default the arm's)."""
    where = arm_segment() if which is None else which
    return lambda ctx, skill, info: np.asarray(info["segment_centers"][where(ctx)], dtype=float)[:2]


def sponge_home() -> Spot:
    """Where the sponge rests at home (world xy, m)."""
    return lambda ctx, skill, info: np.asarray(info["sponge_home_pos"], dtype=float)[:2]


def free_spot(which: Segment | None = None) -> Spot:
    """A spot (world xy, m) of segment ``which`` (default the arm's) where the held object's footprint keeps
    ``object_clearance`` from the objects lying there ([`tableclean_suite.environments.placement.free_spot`][tableclean_suite.environments.placement.free_spot])."""
    where = arm_segment() if which is None else which

    def resolve(ctx: Context, skill, info: Info) -> np.ndarray:
        k = where(ctx)
        lying = [j for j in ctx.state.objects_on(k) if j != ctx.held]
        if ctx.held is not None:  # as the place skill chooses it
            return place_spot(info, k, ctx.held, lying, skill.config["place_clearance"], gripper_of(skill.env))
        others = [(np.asarray(info["objects_pos"][j], dtype=float), footprint_of(info, j)) for j in lying]
        return placement_free_spot(info["segment_centers"][k], info["segment_half_sizes"][k], 0.0, others,
                                   info["object_clearance"],
                                   other_segments(info["segment_centers"], info["segment_half_sizes"], k))
    return resolve


# -- steps --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Step:
    """One primitive of a composed skill: its kind (phase prefix), local phases and how to make it."""

    kind: str
    phases: tuple[str, ...]
    make: Callable[[Context, Info], list]  # -> [(local prefix, Primitive), ...]


def reach(spot: Spot) -> Step:
    """Travel above ``spot`` at the travel height; the gripper stays closed while the skill holds an object."""
    def make(ctx: Context, info: Info) -> list:
        gripper = GRIPPER_CLOSE if ctx.held is not None else GRIPPER_OPEN
        return [("", Reach("GO", lambda skill, info: skill.hover_point(info, spot(ctx, skill, info)), gripper))]
    return Step("REACH", ("GO",), make)


def grasp(obj: Object) -> Step:
    """Take object ``obj`` (the skill holds it afterwards)."""
    def make(ctx: Context, info: Info) -> list:
        if ctx.held is not None:
            raise SkillFailure(f"object {ctx.held + 1} is already held")
        ctx.held = obj(ctx)
        return [("", Grasp(object_body(ctx.held, info), "grasp"))]
    return Step("GRASP", Grasp.PHASES, make)


def release(spot: Spot) -> Step:
    """Put the object the skill holds down on ``spot`` (lowered until it rests), open and retreat."""
    def make(ctx: Context, info: Info) -> list:
        held = ctx.held
        if held is None:
            raise SkillFailure("nothing is held to release")
        ctx.held = None
        return [("", Release(object_body(held), lambda skill, info: spot(_with_held(ctx, held), skill, info),
                             lambda skill, info: float(info["objects_rest_z"][held])))]
    return Step("RELEASE", Release.PHASES, make)


def wipe(which: Segment | None = None) -> Step:
    """Fetch the sponge, wipe segment ``which`` (default the arm's), bring the sponge home (the clean skill's motions)."""
    where = arm_segment() if which is None else which

    def make(ctx: Context, info: Info) -> list:
        return wipe_plan(where(ctx), info)
    return Step("WIPE", WIPE_PHASES, make)


def _with_held(ctx: Context, held: int) -> Context:
    view = Context(ctx.state)
    view.held = held
    return view


# -- the skill ----------------------------------------------------------------------------------
def _camel(name: str) -> str:
    return "".join(part.capitalize() for part in name.split("_"))


def compose_skill(name: str, rule: Callable[[TaskState], tuple], steps: Sequence[Step], *,
                  description: str = "", max_steps: int = DEFAULT_MAX_STEPS,
                  config: Mapping[str, Any] | None = None) -> type[PrimitiveSkill]:
    """A skill class for action ``name`` that runs ``steps`` in order; ``rule`` is the action's symbolic effect.

    The class carries ``rule`` (an [`ActionRule`][tableclean_suite.task.actions.ActionRule]):
    [`register_skill`][tableclean_suite.controllers.registry.register_skill] registers the action with it when the
    action is not registered yet.  Its phases are ``<KIND><i>_<phase>`` (e.g. ``GRASP1_DESCEND``).
    Its config: [`ComposedConfig`][tableclean_suite.controllers.configs.ComposedConfig] (the grasp and release settings), or
    [`CleanConfig`][tableclean_suite.controllers.configs.CleanConfig] when a step wipes, with ``max_steps`` and ``config`` on top
    (keys of that type only, values in its ranges: [`SkillConfigError`][tableclean_suite.controllers.configs.SkillConfigError], a
    ``KeyError`` and a ``ValueError``, naming the skill, the key and the allowed keys or range).
    """
    if not steps:
        raise ValueError(f"skill {name!r}: give at least one step (reach, grasp, release, wipe)")
    members, prefixes = [], []
    for i, step in enumerate(steps, start=1):
        if not isinstance(step, Step):
            raise TypeError(f"skill {name!r}: step {i} is {step!r}, not a reach/grasp/release/wipe step")
        prefix = f"{step.kind}{i}_"
        prefixes.append(prefix)
        members += [prefix + phase for phase in step.phases]
    phase_enum = enum.Enum(f"{_camel(name)}Phase", [*members, "DONE"])
    config_type = CleanConfig if any(step.kind == "WIPE" for step in steps) else ComposedConfig
    # validated here (the check the skill's constructor runs), not when the skill first runs
    defaults = checked_skill_config(f"skill {name!r}", config_type, config_type().as_dict(),
                                    {"max_steps": max_steps, **(config or {})})[1].as_dict()

    def build(self, info: Info):
        ctx = Context(self.state)
        plan = []
        for prefix, step in zip(prefixes, steps):
            plan += [(prefix + local, primitive) for local, primitive in step.make(ctx, info)]
        return plan

    return type(f"{_camel(name)}Skill", (PrimitiveSkill,), {
        "action": name, "Phase": phase_enum, "Config": config_type, "DEFAULT_CONFIG": defaults, "build": build,
        "rule": ActionRule(name, rule, description), "__doc__": description or f"The composed skill of {name!r}.",
    })


__all__ = ["compose_skill", "reach", "grasp", "release", "wipe", "arm_segment", "next_segment",
           "previous_segment", "segment", "lying_object", "held_object", "segment_center", "sponge_home",
           "free_spot", "Step", "Context", "DEFAULT_MAX_STEPS"]
