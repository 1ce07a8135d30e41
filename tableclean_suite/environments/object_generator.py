"""Objects users might bring: procedurally composed MJCF objects, seeded and reproducible.

[`random_objects`][tableclean_suite.environments.object_generator.random_objects] ``(n, seed)`` draws ``n``
object types, each an MJCF file in robosuite's object layout (as a user's, built through
[`xml_object_builder`][tableclean_suite.environments.objects.xml_object_builder]) returned as an
[`ObjectType`][tableclean_suite.environments.objects.ObjectType] that ``register_object`` takes:

    for kind in random_objects(300, seed=1):
        register_object(kind, overwrite=True)

An object is a body (an upright ``cylinder``, a ``box``, or a ``capsule``: a cylinder with a round
top), with each feature its body admits drawn with `ObjectRanges.feature_chance`: a ``cap`` (a
narrower cylinder on top), a ``lip`` (a wider rim at the body's top), a ``handle`` (a capsule
bar on +y held by two connectors) and a ``taper`` (the cylinder in three sections narrowing up or
down).  Sizes, density and friction come from
[`ObjectRanges`][tableclean_suite.environments.object_generator.ObjectRanges].
Object ``i`` of seed ``s`` is drawn from ``numpy.random.SeedSequence([s, i])``: it is the same
whatever ``n``, and the same seed gives the same MJCF text, byte for byte.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass

import numpy as np

from tableclean_suite.environments.objects import ObjectType, xml_object_builder

#: Body shapes and the features each admits.
FEATURES = {"cylinder": ("cap", "lip", "handle", "taper"), "box": ("cap", "lip", "handle"),
            "capsule": ("cap", "handle")}


@dataclass(frozen=True)
class ObjectRanges:
    """The ranges objects are drawn from; each ``(low, high)`` is drawn uniformly unless said otherwise.

    Attributes:
        width: narrowest horizontal width [m], lip included: from a thin bottle to the Panda's open pad gap
            (7.9 cm) less ``GRASP_WIDTH_MARGIN`` (1 cm), the widest the scene accepts.
        height: overall height [m]; the top is the catalog's tallest type (robosuite's bottle, 16 cm).
        slenderness: largest height / narrowest width (the catalog's upright round types reach 3.75).
        span: largest horizontal extent [m] across the narrow side (box sides, handles; the cereal box: 10 cm).
        aspect: a box's long side over its narrow one.
        density: kg/m^3, log-uniform: ``randomization.ALLOWED_SCALE`` (0.25 .. 4) times robosuite's default 1000.
        friction: sliding friction: ``ALLOWED_SCALE[0]`` .. ``MAX_CHECKED_FRICTION_SCALE`` times robosuite's 1.
        feature_chance: probability in [0, 1] of each feature the body admits.
    """

    width: tuple[float, float] = (0.02, 0.069)
    height: tuple[float, float] = (0.03, 0.16)
    slenderness: float = 4.0
    span: float = 0.12
    aspect: tuple[float, float] = (1.0, 2.0)
    density: tuple[float, float] = (250.0, 4000.0)
    friction: tuple[float, float] = (0.25, 1.5)
    feature_chance: float = 0.4


def draw_params(rng: np.random.Generator, ranges: ObjectRanges = ObjectRanges()) -> dict:
    """One object's parameters (lengths in m): ``body``, ``features`` and the numbers the MJCF is built from."""
    body = str(rng.choice(list(FEATURES)))
    features = tuple(f for f in FEATURES[body] if rng.random() < ranges.feature_chance)
    width = rng.uniform(*ranges.width)
    low = max(ranges.height[0], 1.5 * width if body == "capsule" else 0.0)  # room for the round top
    height = rng.uniform(low, max(low, min(ranges.height[1], ranges.slenderness * width)))
    p = {"body": body, "features": features, "width": width, "height": height,
         "density": float(np.exp(rng.uniform(*np.log(ranges.density)))), "friction": rng.uniform(*ranges.friction),
         "rgba": tuple(round(float(c), 3) for c in rng.uniform(0.1, 0.9, 3)),
         "lip": rng.uniform(0.002, 0.006) if "lip" in features else 0.0, "lip_height": rng.uniform(0.003, 0.008),
         "cap_height": rng.uniform(0.01, 0.03) if "cap" in features else 0.0, "cap_radius": rng.uniform(0.4, 0.8),
         "taper": rng.uniform(0.6, 0.9) if "taper" in features else 1.0, "taper_up": bool(rng.random() < 0.5),
         "aspect": min(rng.uniform(*ranges.aspect), ranges.span / width) if body == "box" else 1.0,
         "handle_gap": rng.uniform(0.012, 0.025), "handle_radius": rng.uniform(0.004, 0.007),
         "handle_length": rng.uniform(0.4, 0.7)}
    p["cap_height"] = min(p["cap_height"], 0.25 * height)
    half_y = (width / 2 - p["lip"]) * p["aspect"]
    if "handle" in features and 2 * half_y + p["handle_gap"] + p["handle_radius"] > ranges.span:
        p["features"] = tuple(f for f in features if f != "handle")  # the handle would not fit the span
    return {k: (round(float(v), 5) if isinstance(v, (float, np.floating)) else v) for k, v in p.items()}


def _geoms(p: dict) -> list[tuple[str, tuple, tuple]]:
    """``(type, size, pos)`` of each geom, z from the object's bottom [m]."""
    features, half_x = p["features"], p["width"] / 2 - p["lip"]
    body_top = p["height"] - p["cap_height"]
    geoms = []
    if p["body"] == "box":
        half_y = half_x * p["aspect"]
        geoms.append(("box", (half_x, half_y, body_top / 2), (0, 0, body_top / 2)))
        top_radius = min(half_x, half_y)
    elif p["body"] == "capsule":
        half_y = top_radius = half_x
        geoms += [("capsule", (half_x, max(body_top / 2 - half_x, 1e-4)), (0, 0, body_top / 2)),
                  ("cylinder", (half_x, half_x / 2), (0, 0, half_x / 2))]  # a flat foot under the round bottom
    else:
        radii = half_x * np.linspace(p["taper"], 1.0, 3)
        radii = radii[::-1] if p["taper_up"] else radii
        third = body_top / 3
        geoms += [("cylinder", (r, third / 2), (0, 0, third * (k + 0.5))) for k, r in enumerate(radii)]
        half_y = float(radii.max())
        top_radius = float(radii[-1])
    if "lip" in features:
        rim = p["lip_height"] / 2
        if p["body"] == "box":
            geoms.append(("box", (half_x + p["lip"], half_y + p["lip"], rim), (0, 0, body_top - rim)))
        else:
            geoms.append(("cylinder", (top_radius + p["lip"], rim), (0, 0, body_top - rim)))
    if "cap" in features:
        cap = p["cap_height"] / 2
        geoms.append(("cylinder", (p["cap_radius"] * top_radius, cap), (0, 0, body_top + cap)))
    if "handle" in features:
        bar, reach = p["handle_radius"], half_y + p["handle_gap"]
        length = max(p["handle_length"] * body_top, 4 * bar)
        low, high = (body_top - length) / 2 + bar, (body_top + length) / 2 - bar
        geoms.append(("capsule", (bar, (high - low) / 2), (0, reach, (low + high) / 2)))
        geoms += [("box", (bar, reach / 2, bar), (0, reach / 2, z)) for z in (low, high)]
    return geoms


def object_mjcf(params: dict, name: str = "generated") -> str:
    """The MJCF text (robosuite's object layout, origin at mid-height) of the object with ``params``."""
    def num(values):
        return " ".join(f"{float(v):.5f}" for v in values)

    mid = params["height"] / 2
    attrs = (f'group="0" density="{params["density"]:.3f}" friction="{params["friction"]:.5f} 0.005 0.0001" '
             f'rgba="{num(params["rgba"])} 1"')
    geoms = "\n".join(f'        <geom type="{kind}" size="{num(size)}" pos="{num((x, y, z - mid))}" {attrs}/>'
                      for kind, size, (x, y, z) in _geoms(params))
    radius = params["width"] / 2
    return (f'<mujoco model="{name}">\n  <worldbody>\n    <body>\n      <body name="object">\n{geoms}\n      </body>\n'
            f'      <site rgba="0 0 0 0" size="0.005" pos="0 0 {-mid:.5f}" name="bottom_site"/>\n'
            f'      <site rgba="0 0 0 0" size="0.005" pos="0 0 {mid:.5f}" name="top_site"/>\n'
            f'      <site rgba="0 0 0 0" size="0.005" pos="{radius:.5f} {radius:.5f} 0" '
            f'name="horizontal_radius_site"/>\n'
            f'    </body>\n  </worldbody>\n</mujoco>\n')


class MJCFBuild:
    """An object type's ``build(name, task_config)`` from MJCF text (``mjcf``), written once to a file named
    by its hash in the system's temporary directory (robosuite reads objects from files)."""

    def __init__(self, mjcf: str):
        self.mjcf = mjcf
        self._build = None

    def __call__(self, name, config):
        if self._build is None:
            path = os.path.join(tempfile.gettempdir(), "tableclean_objects",
                                hashlib.sha256(self.mjcf.encode()).hexdigest()[:16] + ".xml")
            os.makedirs(os.path.dirname(path), exist_ok=True)
            if not os.path.isfile(path):
                with tempfile.NamedTemporaryFile("w", dir=os.path.dirname(path), delete=False, suffix=".xml") as out:
                    out.write(self.mjcf)
                os.replace(out.name, path)  # atomic: parallel processes never read half a file
            self._build = xml_object_builder(path)
        return self._build(name, config)


def describe(params: dict) -> str:
    """One line: body, features, sizes [cm], density, friction."""
    return (f"{params['body']}{''.join(' +' + f for f in params['features'])}, {params['width'] * 100:.1f} cm wide, "
            f"{params['height'] * 100:.1f} cm tall, {params['density']:.0f} kg/m^3, friction {params['friction']:.2f}")


def random_objects(n: int, seed: int, ranges: ObjectRanges = ObjectRanges(), prefix: str = "gen") -> list[ObjectType]:
    """``n`` (>= 0) generated object types named ``{prefix}{seed}_{i}``; object ``i`` is drawn from
    ``SeedSequence([seed, i])`` (seed >= 0).  Each type's ``build.mjcf`` is its MJCF text, ``build.params`` the
    drawn parameters and ``description``
    [`describe`][tableclean_suite.environments.object_generator.describe]'s line."""
    if not isinstance(n, (int, np.integer)) or n < 0:
        raise ValueError(f"random_objects: n must be an int >= 0, got {n!r}")
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"random_objects: seed must be an int >= 0, got {seed!r}")
    kinds = []
    for i in range(n):
        params = draw_params(np.random.default_rng(np.random.SeedSequence([int(seed), i])), ranges)
        name = f"{prefix}{seed}_{i}"
        build = MJCFBuild(object_mjcf(params, name))
        build.params = params
        kinds.append(ObjectType(name, build, description=describe(params)))
    return kinds


__all__ = ["ObjectRanges", "random_objects", "draw_params", "object_mjcf", "describe", "MJCFBuild", "FEATURES"]
