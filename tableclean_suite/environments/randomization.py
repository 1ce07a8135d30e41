"""Randomised dynamics of the ``TableClean`` scene, drawn at every reset from the env's seeded ``rng``.

``robosuite.make("TableClean", ..., randomization=...)`` (and ``make_skill_env(randomization=...)``)
takes a [`DynamicsRandomization`][tableclean_suite.environments.randomization.DynamicsRandomization]: the ranges, one named field each, from which every reset
draws a [`DynamicsSample`][tableclean_suite.environments.randomization.DynamicsSample] (the fields, their units,
`DEFAULT_ON`'s ranges and what each is applied to: the table of the physics-and-fidelity docs page).
Scales multiply the value the scene builds (sizes apply to the types built from ``object_half_size``).
Every range is ``(low, high)`` with ``low <= high`` inside `ALLOWED_SCALE` (sizes: `ALLOWED_SIZE_SCALE`,
friction up to `MAX_CHECKED_FRICTION_SCALE`); noises are half-widths >= 0 up to `MAX_YAW_NOISE` /
`MAX_SPONGE_HOME_NOISE`.  Anything else raises ``ValueError`` naming the field.

A reset's sample is drawn from ``env.rng`` first (fixed order), so ``seed=S`` reproduces the scene; ``OFF``
draws nothing.  A size draw rebuilds the MuJoCo model (also with ``hard_reset=False``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields, replace
from typing import Any, Mapping, NamedTuple

import numpy as np

from tableclean_suite.environments.config import jsonable, make_config

__all__ = ["DynamicsRandomization", "DynamicsSample", "OFF", "DEFAULT_ON", "resolve_randomization",
           "ALLOWED_SCALE", "ALLOWED_SIZE_SCALE", "MAX_YAW_NOISE", "MAX_SPONGE_HOME_NOISE", "RANGE_FIELDS",
           "NOISE_FIELDS"]

#: Bounds [factor] every scale range must lie in (outside it the scene stops being the task).
ALLOWED_SCALE = (0.25, 4.0)
#: Bounds [factor] of the size scales: the Panda's fingers open 8 cm; objects must still fit a segment.
ALLOWED_SIZE_SCALE = (0.75, 1.25)
#: Largest friction scale [factor] the skills were checked on (above it the wiping skill loses the sponge).
MAX_CHECKED_FRICTION_SCALE = 1.5
#: Largest yaw noise half-width [rad] (a quarter turn covers every box orientation).
MAX_YAW_NOISE = math.pi / 4
#: Largest sponge-home xy noise half-width [m] (its corner stays inside the default sponge_home_tolerance).
MAX_SPONGE_HOME_NOISE = 0.02

#: (low, high) range fields and their allowed bounds.
RANGE_FIELDS = {
    "object_mass_scale": ALLOWED_SCALE,
    "sponge_mass_scale": ALLOWED_SCALE,
    "object_size_scale": ALLOWED_SIZE_SCALE,
    "sponge_size_scale": ALLOWED_SIZE_SCALE,
    "friction_scale": (ALLOWED_SCALE[0], MAX_CHECKED_FRICTION_SCALE),
    "joint_damping_scale": ALLOWED_SCALE,
    "osc_kp_scale": ALLOWED_SCALE,
    "osc_damping_ratio_scale": ALLOWED_SCALE,
}
#: Half-width fields and their largest allowed value.
NOISE_FIELDS = {
    "object_yaw_noise": MAX_YAW_NOISE,
    "sponge_home_noise": MAX_SPONGE_HOME_NOISE,
    "sponge_yaw_noise": MAX_YAW_NOISE,
}
#: The names users may say for "no randomisation" and "the documented default ranges".
OFF_NAMES = ("off", "paper", "none")
ON_NAMES = ("on", "default")
#: Key of a randomization mapping naming what its overrides start from (``"on"`` or ``"off"``).
BASE_KEY = "base"

Range = tuple[float, float]


@dataclass(frozen=True)
class DynamicsSample:
    """The values one reset drew (units as in [`DynamicsRandomization`][tableclean_suite.environments.randomization.DynamicsRandomization]): ``object_*`` (M,) per object,
    ``joint_damping_scale`` (n_joints,), ``object_yaw_noise`` the half-width the placement used [rad],
    ``sponge_home_offset`` (2,) [m] and ``sponge_yaw`` [rad] the sponge's start; the rest floats."""

    object_mass_scale: tuple[float, ...]
    sponge_mass_scale: float
    object_size_scale: tuple[float, ...]
    sponge_size_scale: float
    table_friction_scale: float
    object_friction_scale: tuple[float, ...]
    sponge_friction_scale: float
    joint_damping_scale: tuple[float, ...]
    osc_kp_scale: float
    osc_damping_ratio_scale: float
    object_yaw_noise: float
    sponge_home_offset: tuple[float, float]
    sponge_yaw: float

    def to_dict(self) -> dict:
        """Plain JSON-serialisable values (lists for the tuples)."""
        return jsonable(asdict(self))


@dataclass(frozen=True)
class DynamicsRandomization:
    """Ranges of the randomised dynamics: ``(low, high)`` tuples, noises half-widths.
    ``DynamicsRandomization()`` is `OFF`; `DEFAULT_ON` the documented ranges."""

    object_mass_scale: Range = (1.0, 1.0)  #: factor on each object's mass and inertia
    sponge_mass_scale: Range = (1.0, 1.0)  #: factor on the sponge's mass and inertia
    object_size_scale: Range = (1.0, 1.0)  #: factor on each object's half extents (types built from the config)
    sponge_size_scale: Range = (1.0, 1.0)  #: factor on the sponge's half extents
    friction_scale: Range = (1.0, 1.0)  #: factor on the table's, each object's and the sponge's sliding friction
    joint_damping_scale: Range = (1.0, 1.0)  #: factor on each arm joint's damping (drawn apart)
    osc_kp_scale: Range = (1.0, 1.0)  #: factor on the OSC stiffness kp (all six axes)
    osc_damping_ratio_scale: Range = (1.0, 1.0)  #: factor on the OSC damping ratio (kd = 2 sqrt(kp) ratio)
    object_yaw_noise: float = 0.0  #: rad, objects' start yaw uniform in +-this
    sponge_home_noise: float = 0.0  #: m, sponge start xy on its stand, +-this
    sponge_yaw_noise: float = 0.0  #: rad, sponge start yaw, +-this

    def __post_init__(self):
        for name, (lowest, highest) in RANGE_FIELDS.items():
            value = getattr(self, name)
            if not (isinstance(value, (tuple, list)) and len(value) == 2
                    and all(isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_))
                            for v in value)):
                raise ValueError(f"randomization {name} must be a (low, high) pair of numbers, got {value!r}")
            low, high = (float(v) for v in value)
            if not (math.isfinite(low) and math.isfinite(high) and lowest <= low <= high <= highest):
                why = (" (the skills were checked up to this: above it the wiping skill loses the sponge)"
                       if name == "friction_scale" and high > highest else "")
                raise ValueError(f"randomization {name} must be (low, high) with {lowest} <= low <= high <= {highest}, "
                                 f"got {value!r}{why}")
            object.__setattr__(self, name, (low, high))
        for name, largest in NOISE_FIELDS.items():
            value = getattr(self, name)
            number = isinstance(value, (int, float, np.integer, np.floating))
            if not (number and not isinstance(value, (bool, np.bool_)) and 0.0 <= float(value) <= largest):
                raise ValueError(f"randomization {name} must be a half-width in [0, {largest:.4g}], got {value!r}")
            object.__setattr__(self, name, float(value))

    @property
    def enabled(self) -> bool:
        """Whether anything is randomised: some range other than (1, 1) or some noise above 0 (``OFF``: False)."""
        return self != OFF

    def to_dict(self) -> dict:
        """The ranges as plain values (lists for the pairs)."""
        return jsonable(asdict(self))

    def sample(self, rng: np.random.Generator, n_objects: int, n_joints: int) -> DynamicsSample:
        """Draw one [`DynamicsSample`][tableclean_suite.environments.randomization.DynamicsSample] for ``n_objects`` objects and ``n_joints`` arm joints,
        from ``rng`` in a fixed order (a point range still consumes its draws)."""

        def draw(name, size=None):
            low, high = getattr(self, name)
            values = rng.uniform(low, high, size=size)
            return float(values) if size is None else tuple(float(v) for v in values)

        return DynamicsSample(
            object_mass_scale=draw("object_mass_scale", n_objects), sponge_mass_scale=draw("sponge_mass_scale"),
            object_size_scale=draw("object_size_scale", n_objects), sponge_size_scale=draw("sponge_size_scale"),
            table_friction_scale=draw("friction_scale"), object_friction_scale=draw("friction_scale", n_objects),
            sponge_friction_scale=draw("friction_scale"), joint_damping_scale=draw("joint_damping_scale", n_joints),
            osc_kp_scale=draw("osc_kp_scale"), osc_damping_ratio_scale=draw("osc_damping_ratio_scale"),
            object_yaw_noise=self.object_yaw_noise,
            sponge_home_offset=tuple(float(v) for v in rng.uniform(-self.sponge_home_noise, self.sponge_home_noise, 2)),
            sponge_yaw=float(rng.uniform(-self.sponge_yaw_noise, self.sponge_yaw_noise)))


#: No randomisation: the paper's scene (the default everywhere).
OFF = DynamicsRandomization()
#: The documented default ranges.
DEFAULT_ON = DynamicsRandomization(
    object_mass_scale=(0.7, 1.5), sponge_mass_scale=(0.7, 1.5), object_size_scale=(0.9, 1.1),
    sponge_size_scale=(0.9, 1.1), friction_scale=(0.7, 1.3), joint_damping_scale=(0.5, 2.0),
    osc_kp_scale=(0.8, 1.2), osc_damping_ratio_scale=(0.8, 1.2), object_yaw_noise=0.3, sponge_home_noise=0.01,
    sponge_yaw_noise=0.15)


def _preset(name) -> DynamicsRandomization | None:
    """`OFF` or `DEFAULT_ON` for one of their names (any case), else None."""
    name = name.strip().lower() if isinstance(name, str) else None
    return OFF if name in OFF_NAMES else DEFAULT_ON if name in ON_NAMES else None


def resolve_randomization(value: Any) -> DynamicsRandomization:
    """The [`DynamicsRandomization`][tableclean_suite.environments.randomization.DynamicsRandomization] of a user value; ``ValueError`` naming it and what is allowed.

    Accepts ``None``/``False``/``"off"``/``"paper"``/``"none"`` (`OFF`), ``True``/``"on"``/``"default"``
    (`DEFAULT_ON`), a ``DynamicsRandomization``, or a mapping of field overrides on top of `DEFAULT_ON`
    (its key ``"base": "off"`` starts them from `OFF` instead).
    """
    if value is None or value is False:
        return OFF
    if value is True:
        return DEFAULT_ON
    if isinstance(value, DynamicsRandomization):
        return value
    if isinstance(value, str):
        if _preset(value):
            return _preset(value)
        raise ValueError(f"unknown randomization {value!r}; allowed: {', '.join(OFF_NAMES + ON_NAMES)}, "
                         "a DynamicsRandomization or a mapping of its fields")
    if isinstance(value, Mapping):
        known = {f.name for f in fields(DynamicsRandomization)}
        unknown = sorted(set(map(str, value)) - known - {BASE_KEY})
        if unknown:
            raise ValueError(f"unknown randomization field(s) {unknown}; allowed: {sorted(known)} and {BASE_KEY!r}")
        overrides = dict(value)
        base_name = overrides.pop(BASE_KEY, ON_NAMES[0])
        base = _preset(base_name)
        if base is None:
            raise ValueError(f"randomization {BASE_KEY!r} must be one of {', '.join(ON_NAMES + OFF_NAMES)}, "
                             f"got {base_name!r}")
        return replace(base, **overrides)
    raise ValueError(f"randomization must be None, True/False, {', '.join(OFF_NAMES + ON_NAMES)}, "
                     f"a DynamicsRandomization or a mapping of its fields, got {value!r}")


# -- applying a draw to the scene --------------------------------------------------------------
def episode_config(base: Mapping, sample: DynamicsSample) -> Mapping:
    """The task config of an episode drawn as ``sample`` from the configured ``base``: the sponge's half size
    scaled, the objects' yaw noise at least the drawn one (a new checked config)."""
    sponge = np.asarray(base["sponge_half_size"], dtype=float) * sample.sponge_size_scale
    yaw_noise = max(float(base["placement_yaw_noise"]), sample.object_yaw_noise)
    return make_config({**base, "sponge_half_size": tuple(float(h) for h in sponge),
                        "placement_yaw_noise": yaw_noise})


def object_build_config(base: Mapping, config: Mapping, sample: DynamicsSample | None, obj: int) -> Mapping:
    """The config object ``obj`` (0-based) is built from: the episode's ``config`` with ``base``'s
    ``object_half_size`` scaled by the draw (``config`` itself without a draw)."""
    if sample is None:
        return config
    half = np.asarray(base["object_half_size"], dtype=float)
    return {**config, "object_half_size": half * sample.object_size_scale[obj]}


class DynamicsTargets(NamedTuple):
    """What a draw scales in the built model."""

    bodies: np.ndarray  #: (M + 1,) body ids
    table: np.ndarray  #: bool (ngeom,)
    objects: tuple  #: (M,) bool (ngeom,) each
    sponge: np.ndarray  #: bool (ngeom,)
    arm_dofs: np.ndarray  #: the arm joints' dof indexes


def read_nominal(model, targets: DynamicsTargets) -> dict:
    """Copies of the values of ``model`` (a freshly built MuJoCo model) a draw scales."""
    return {
        "body_mass": model.body_mass[targets.bodies].copy(),
        "body_inertia": model.body_inertia[targets.bodies].copy(),
        "table_friction": model.geom_friction[targets.table, 0].copy(),
        "object_friction": [model.geom_friction[mask, 0].copy() for mask in targets.objects],
        "sponge_friction": model.geom_friction[targets.sponge, 0].copy(),
        "dof_damping": model.dof_damping[targets.arm_dofs].copy(),
    }


def apply_dynamics(model, targets: DynamicsTargets, nominal: dict, sample: DynamicsSample, osc) -> None:
    """Write ``sample``'s masses, frictions and damping into ``model`` and its gains into the arm's
    controller ``osc``: scales multiply the ``nominal`` values ([read_nominal][tableclean_suite.environments.randomization.read_nominal]),
    so soft resets do not compound.  ``ValueError`` when the gains are scaled and ``osc`` has no ``kp``/``kd``."""
    bodies = targets.bodies
    mass_scale = np.array([*sample.object_mass_scale, sample.sponge_mass_scale])
    model.body_mass[bodies] = nominal["body_mass"] * mass_scale
    model.body_inertia[bodies] = nominal["body_inertia"] * mass_scale[:, None]
    model.geom_friction[targets.table, 0] = nominal["table_friction"] * sample.table_friction_scale
    for mask, values, scale in zip(targets.objects, nominal["object_friction"], sample.object_friction_scale):
        model.geom_friction[mask, 0] = values * scale
    model.geom_friction[targets.sponge, 0] = nominal["sponge_friction"] * sample.sponge_friction_scale
    model.dof_damping[targets.arm_dofs] = nominal["dof_damping"] * np.asarray(sample.joint_damping_scale)
    scales_gains = sample.osc_kp_scale != 1.0 or sample.osc_damping_ratio_scale != 1.0
    if not (hasattr(osc, "kp") and hasattr(osc, "kd")):  # not an OSC: its gains cannot be scaled
        if scales_gains:
            raise ValueError(f"randomization scales OSC gains (osc_kp_scale, osc_damping_ratio_scale), but the "
                             f"arm's controller {type(osc).__name__} has no kp/kd; set both ranges to (1, 1)")
    else:  # robosuite made the controller anew at this reset: scaling does not compound
        kp = np.asarray(osc.kp, dtype=float)
        ratio = np.asarray(osc.kd, dtype=float) / (2.0 * np.sqrt(kp))  # the controller's damping ratio
        osc.kp = kp * sample.osc_kp_scale
        osc.kd = 2.0 * np.sqrt(osc.kp) * ratio * sample.osc_damping_ratio_scale
