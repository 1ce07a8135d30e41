"""The ``TableClean`` robosuite environment: an N-segment dirty table, M objects, a sponge and a Panda."""

from __future__ import annotations

import enum
from typing import Any, Iterable, Mapping, NamedTuple

import mujoco
import numpy as np
from robosuite.environments.manipulation.manipulation_env import ManipulationEnv
from robosuite.models.tasks import ManipulationTask
from robosuite.utils.observables import Observable, sensor
from robosuite.utils.transform_utils import convert_quat, mat2quat

from tableclean_suite.environments import abstraction, dirt_state, wiping
from tableclean_suite.environments.arena import TableCleanArena
from tableclean_suite.environments import placement
from tableclean_suite.environments.contact_kernels import (
    LOOKUP_BODY,
    LOOKUP_PADS,
    NATIVE_CONTACT_FORCE,
    NATIVE_DATA,
    NATIVE_MODEL,
    PAD_A,
    PAD_B,
    PRESSING,
    SURFACE,
    contact_within,
    contacts_between,
    grasped_bodies,
    press_normal_force,
)
from tableclean_suite.environments.config import (
    DEFAULT_TABLECLEAN_CONFIG,
    make_config,
    marker_positions,
    scene_geometry,
)
from tableclean_suite.environments.ik import site_pose, solve_site_pose
from tableclean_suite.environments.gripper_geometry import measure_gripper
from tableclean_suite.environments.object_geometry import object_geometry
from tableclean_suite.environments.objects import (
    check_holdable,
    footprint_radius,
    get_object_type,
    make_object,
    make_sponge,
    object_names,
    type_geometry,
)
from tableclean_suite.environments.robot_support import (
    check_scene_robot,
    exclude_parent_contacts,
    scene_base_shift,
    scene_gripper,
)
from tableclean_suite.environments.randomization import (
    DynamicsRandomization,
    DynamicsSample,
    resolve_randomization,
)
from tableclean_suite.environments.scene_state import SceneState
from tableclean_suite.environments.skill_info import SkillInfo
from tableclean_suite.robosuite_adapter import (
    c_address,
    gripper_joint_pos_indexes,
    joint_vel_indexes,
    mj_data,
    mj_model,
    mujoco_contact_force_address,
)
from tableclean_suite.task import HELD, StartMode, TaskModel, TaskSpec, TaskState, get_task_spec

__all__ = ["TableClean", "DEFAULT_TABLECLEAN_CONFIG"]

#: robosuite's name of the table's collision geom: the surface the sponge must press on.
TABLE_TOP_GEOM = "table_collision"
#: Entries of ``mujoco.mj_contactForce``'s output: normal force first, then two tangential, three torques.
CONTACT_WRENCH_SIZE = 6
#: Value of the ``symbolic_state_index`` observable when the abstraction reports a fault.
FAULT_INDEX = -1
#: Height above the table top at which a dropped object is placed, so it settles without penetration [m].
PLACEMENT_CLEARANCE = 0.001
#: A randomised sponge start keeps its footprint this far inside its stand's edges [m].
STAND_EDGE_MARGIN = 0.002
#: At reset the grip site hovers at least this far above the tallest object's top [m] (the open
#: fingertips hang ~1.4 cm below it on the Panda gripper), so a tall object is not knocked over.
RESET_OBJECT_CLEARANCE = 0.05
#: The exact contact test runs only when the sponge's lowest corner is within this of the table top [m].
PRESS_PREFILTER_SLACK = 0.002


#: Indexes of a MuJoCo wxyz quaternion's entries in robosuite's xyzw order (``convert_quat(q, to="xyzw")``
#: as a gather).
XYZW_FROM_WXYZ = np.array([1, 2, 3, 0], dtype=np.intp)


class _DataViews(NamedTuple):
    """What :meth:`TableClean.skill_info` reads every control step: views into ``data`` (flat for the bodies'
    positions and quaternions) and the indexes gathering the rows it reports (the quaternions' in xyzw order)."""

    data: Any  #: the mjData the views belong to
    eef_pos: np.ndarray  #: (3,) grip-site position [m]
    eef_xmat: np.ndarray  #: (9,) grip-site rotation matrix, row-major
    qpos: np.ndarray  #: (nq,)
    fingers: np.ndarray  #: finger joints' qpos indexes
    xpos: np.ndarray  #: (nbody * 3,) body positions [m]
    xquat: np.ndarray  #: (nbody * 4,) body quaternions, wxyz
    objects_pos: np.ndarray  #: (M, 3) indexes into xpos
    objects_quat: np.ndarray  #: (M, 4) indexes into xquat, xyzw order
    sponge_pos: np.ndarray  #: (3,) indexes into xpos
    sponge_quat: np.ndarray  #: (4,) indexes into xquat, xyzw order


# Un-normalised reward components (see TableClean.reward).
SUCCESS_REWARD = 3.0
WIPE_REWARD_PER_SEGMENT = 1.0
OBJECT_ON_TABLE_REWARD = 0.25
SPONGE_RETURNED_REWARD = 0.5
#: The wiping component spans [0, this] (the paper's two segments) whatever the number of segments.
PAPER_REWARD_SEGMENTS = 2
class _LayoutDefault(enum.Enum):
    """:data:`FROM_SPEC`'s type: a sentinel compared by identity (a string spelled ``"from_spec"`` is a
    layout value, not the default) and kept through pickling."""

    FROM_SPEC = "from_spec"

    def __repr__(self) -> str:
        return self.name


#: Default of the layout arguments: with ``task=`` given, the layout comes from the spec's start
#: (``start_state`` for ``fixed``, a fresh draw at each reset for ``uniform_unclean``); without it,
#: each is drawn at each reset (v3's default).
FROM_SPEC = _LayoutDefault.FROM_SPEC


def _segment_numbers(n_segments: int) -> str:
    """The 1-based segment numbers of the scene, as text for error messages (e.g. "1, 2")."""
    return ", ".join(str(k) for k in range(1, n_segments + 1))


def _segment_option(name: str, value, n_segments: int) -> int | None:
    """``None`` (random each reset) or the 0-based index of a 1-based segment number; clear ``ValueError`` otherwise."""
    if value is None:
        return None
    if isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_)) and 1 <= value <= n_segments:
        return int(value) - 1
    raise ValueError(f"{name} must be {_segment_numbers(n_segments)} or None (random at each reset), got {value!r}")


def _dirty_option(value: Iterable[int] | None, n_segments: int) -> tuple[int, ...]:
    """Sorted 0-based indices of the 1-based segment numbers in ``value`` (None: all); clear ``ValueError`` otherwise."""
    if value is None:
        return tuple(range(n_segments))
    allowed = _segment_numbers(n_segments)
    try:
        numbers = tuple(value)
    except TypeError:
        raise ValueError(f"dirty_segments must be a collection of segment numbers ({allowed}), got {value!r}") from None
    segments = tuple(_segment_option("dirty_segments entry", n, n_segments) for n in numbers)
    if None in segments:
        raise ValueError(f"dirty_segments must contain only segment numbers ({allowed}), got {value!r}")
    return tuple(sorted(set(segments)))


def _jsonable(value):
    """``value`` with tuples and NumPy values turned into lists and Python scalars (for JSON)."""
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value


def object_outline(kind, shape, radius: float | None = None) -> np.ndarray:
    """(K, 2) outline [m] of an upright object of type ``kind`` seen from above in its own frame: a disc of
    ``radius`` (default its ``footprint_radius``) when the type overrides the footprint, else its collision
    geometry ``shape``'s (:func:`.placement.outline_of`)."""
    if kind.footprint_radius is not None:
        return placement.disc_outline(float(kind.footprint_radius) if radius is None else radius)
    return placement.outline_of(shape.hull)


def check_objects_fit(kinds, geometry, config: Mapping, size_scale: float = 1.0) -> None:
    """Raise ``ValueError`` unless the objects of ``kinds`` (ObjectTypes) fit side by side on one segment.

    Every spec can bring all its objects onto one segment, so all M must fit there, by their
    oriented footprints (:func:`.placement.row_layout`: turned so their narrowest width lies along
    the row where that helps, without yaw noise, which the reset caps).  ``size_scale`` (> 0)
    multiplies every footprint: the largest ``object_size_scale`` a randomisation can draw.  The
    message names the objects, the size their grid needs and the segment's.
    """
    half = np.asarray(geometry.segment_half_sizes[0], dtype=float)
    scaled = f" at object size scale {size_scale:g}" if size_scale != 1.0 else ""
    segment = f"{2 * half[0] * 100:.1f} x {2 * half[1] * 100:.1f} cm"

    def layout(outlines):
        return placement.row_layout(outlines, half, config["object_spacing"], config["object_clearance"], 0.0)

    outlines = []
    for kind in kinds:
        outline = object_outline(kind, type_geometry(kind, config)) * size_scale
        try:
            layout([outline])
        except placement.DoesNotFit as error:
            raise ValueError(f"object {kind.name!r} does not fit a segment{scaled}: its footprint is "
                             f"{error.size[0] * 100:.1f} x {error.size[1] * 100:.1f} cm (even turned with its narrowest "
                             f"width along x), a segment {segment}") from None
        outlines.append(outline)
    try:
        layout(outlines)
    except placement.DoesNotFit as error:
        raise ValueError(f"{len(kinds)} objects ({', '.join(k.name for k in kinds)}) do not fit side by side on one "
                         f"segment{scaled}: {error}; use fewer or smaller objects") from None


#: Non-finite action entries an error message lists.
MAX_NAMED_ENTRIES = 4


def check_finite_action(action) -> None:
    """``ValueError`` unless ``action`` is a flat sequence of finite numbers (the entries that are not are named)."""
    try:
        values = np.asarray(action, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"action must be a sequence of numbers, got {action!r}") from None
    bad = np.flatnonzero(~np.isfinite(values.ravel()))
    if bad.size:
        shown = ", ".join(f"[{i}] = {values.ravel()[i]}" for i in bad[:MAX_NAMED_ENTRIES])
        raise ValueError(f"action has {bad.size} non-finite entr{'y' if bad.size == 1 else 'ies'} ({shown}); "
                         "every entry must be a finite number")


def check_episode_settings(horizon, control_freq) -> None:
    """``ValueError`` naming ``horizon`` (an integer >= 1, control steps) or ``control_freq`` (a number > 0, Hz)."""
    if isinstance(horizon, bool) or not isinstance(horizon, (int, np.integer)) or horizon < 1:
        raise ValueError(f"horizon must be an integer >= 1 (control steps per episode), got {horizon!r}")
    if isinstance(control_freq, bool) or not isinstance(control_freq, (int, float, np.number)) \
            or not np.isfinite(control_freq) or control_freq <= 0:
        raise ValueError(f"control_freq must be a number > 0 (Hz), got {control_freq!r}")


def check_controller_configs(controller_configs) -> None:
    """``ValueError`` for a controller config robosuite would refuse with an assertion: not a dict, or a
    ``type`` that is not one of robosuite's composite or part controllers (named)."""
    if controller_configs is None:
        return
    from robosuite.controllers import ALL_COMPOSITE_CONTROLLERS, ALL_PART_CONTROLLERS

    allowed = [*ALL_COMPOSITE_CONTROLLERS, *ALL_PART_CONTROLLERS]
    configs = controller_configs if isinstance(controller_configs, (list, tuple)) else [controller_configs]
    for config in configs:
        if not isinstance(config, Mapping):
            raise ValueError(f"controller_configs must be a dict (e.g. robosuite.load_composite_controller_config"
                             f"(controller='BASIC')), got {config!r}")
        kind = config.get("type")
        if kind not in allowed:
            raise ValueError(f"unknown controller type {kind!r}; allowed: {', '.join(allowed)}")


class TableClean(ManipulationEnv):
    """Clean every segment of a table with a sponge, moving objects out of the way (one Panda arm).

    ## Description
    The scene builds a task spec (``task``, default ``paper``): N segments and M objects of the
    spec's types (:mod:`.objects` registry).  For the paper's N = 2 the table top is split along y
    into segment 1 (at -y, blue tint) and segment 2 (at +y, orange tint); N = 3, 4 lay out two
    rows of two smaller segments within the Panda's reach (:func:`.config.segment_layout`; larger
    N raise a ``ValueError`` naming the limit).  Each segment is covered with a grid of dirt
    markers.  The objects lie on segments, apart (:mod:`.placement`); a sponge rests on a stand
    at the table's side, off every segment.  A dirt marker is wiped when the
    sponge's underside presses on it: the sponge touches the table top and the marker lies under its
    footprint.  This is checked at every physics substep.  The wiped flags are MuJoCo state: each
    segment's dirt-state joint encodes them in its position (:mod:`.dirt_state`), so
    ``sim.get_state()`` / ``sim.set_state_from_flattened()`` (robosuite's ``DataCollectionWrapper``
    and its playback, robomimic's ``dataset_states_to_obs``) save and restore the cleaning with the
    object and the arm.  Wiped markers are hidden (alpha 0) once per control step, and whenever
    observations are made or the env renders, from that state.

    ## Starting State
    The arm's gripper hovers ``arm_hover_height`` above the centre of ``arm_segment`` (pose from a
    cached, deterministic IK solve, plus robosuite's ``initialization_noise``) with the gripper
    open; the object lies on ``object_segment`` with ``placement_noise``; the sponge is at home;
    the segments in ``dirty_segments`` are fully dirty, the others clean.  With the defaults and
    ``object_segment=arm_segment=1`` :meth:`symbolic_state` is Table 1's state 4.

    ## Rewards
    See :meth:`reward`: sparse success by default, staged with ``reward_shaping=True``.

    ## Episode End
    After ``horizon`` steps unless ``ignore_done``.  :meth:`_check_success` reports task success.

    ## Arguments
    Task-specific (all others are those of
    :class:`robosuite.environments.manipulation.manipulation_env.ManipulationEnv`, passed through):

    - ``robots``: one robot name with a registered skill config
      (:func:`tableclean_suite.controllers.robot_configs.supported_robots`, e.g. ``"Panda"``);
      others raise a ``ValueError`` naming the supported ones.  ``gripper_types="default"`` mounts the
      gripper the robot's config names (UR5e, Kinova3: the Panda gripper), else robosuite's default.
    - ``task`` (name, :class:`~tableclean_suite.task.TaskSpec` or ``.json`` path; default ``"paper"``):
      the task spec the scene builds (N segments, the objects' types).
    - Layout (``object_segment``, ``object_segments``, ``arm_segment``, ``dirty_segments``): when
      none is given and ``task`` is, the scene starts where the spec says: its ``start_state``
      (``start="fixed"``; a state holding an object is refused, stage it with
      :func:`tableclean_suite.physics_backend.stage`) or a uniform draw over every all-unclean
      layout at each reset (``start="uniform_unclean"``).  Any layout argument given wins over
      the spec (the others then keep their defaults below); without ``task`` every layout is drawn.
    - ``object_segment`` (1..N or None): segment every object starts on; None draws each at each reset.
    - ``object_segments`` (sequence of M entries 1..N or None): per-object start segments; overrides
      ``object_segment``.
    - ``arm_segment`` (1..N or None): segment the arm starts above; None draws it at each reset.
    - ``dirty_segments`` (collection of 1..N, None = all): segments that start dirty (default all).
    - ``task_config`` (dict): overrides of :data:`DEFAULT_TABLECLEAN_CONFIG` (unknown keys raise).
    - ``use_object_obs`` (bool): include object, sponge, dirt and symbolic observables.
    - ``reward_scale`` (float or None): the maximum reward; None leaves rewards un-normalised.
    - ``reward_shaping`` (bool): use the staged dense reward.
    - ``randomization`` (None/"off", "on", a
      :class:`~tableclean_suite.environments.randomization.DynamicsRandomization` or a mapping of
      its fields, overriding the "on" ranges unless it says ``"base": "off"``): randomised dynamics drawn at every reset from ``self.rng`` (object and sponge
      mass and size, friction, arm joint damping, OSC gains, object yaw and sponge start noise;
      ranges and units in :mod:`.randomization`).  Default off: the unrandomised scene.  The
      reset's draw is ``self.dynamics_sample``; ``self.task_config`` then holds the episode's
      sponge size (``self.base_task_config`` the configured one).

    ## Version History
    - v4: ``task=`` without layout arguments starts in the spec's start (v3 drew the layout).
    - v3: ``randomization=`` (off by default: v2's scene, draws and ``get_ep_meta()``).
    - v2: ``task=``: N segments and M objects of registered types from the task spec (the paper spec
      builds v1's scene: same layout, names and ``qpos``).
    - v1: the wiped flags are MuJoCo state (one dirt-state joint per segment: ``qpos`` and ``qvel``
      gain one entry per segment, so states recorded with v0 do not load); ``get_ep_meta()``
      records the task spec, the task config and the start layout.
    - v0: initial version.
    """

    def __init__(
        self,
        robots,
        object_segment: int | None = FROM_SPEC,
        arm_segment: int | None = FROM_SPEC,
        dirty_segments: Iterable[int] | None = FROM_SPEC,
        task_config: Mapping | None = None,
        task: "str | TaskSpec | None" = None,
        object_segments: Iterable[int | None] | None = FROM_SPEC,
        randomization: "DynamicsRandomization | str | Mapping | bool | None" = None,
        env_configuration="default",
        controller_configs=None,
        gripper_types="default",
        base_types="default",
        initialization_noise="default",
        use_camera_obs=True,
        use_object_obs=True,
        reward_scale=1.0,
        reward_shaping=False,
        has_renderer=False,
        has_offscreen_renderer=True,
        render_camera="frontview",
        render_collision_mesh=False,
        render_visual_mesh=True,
        render_gpu_device_id=-1,
        control_freq=20,
        lite_physics=True,
        horizon=1000,
        ignore_done=False,
        hard_reset=True,
        camera_names="agentview",
        camera_heights=256,
        camera_widths=256,
        camera_depths=False,
        camera_segmentations=None,
        renderer="mjviewer",
        renderer_config=None,
        seed=None,
    ):
        #: robosuite's name of the arm; ValueError naming the supported robots before anything is built
        self.robot_name: str = check_scene_robot(robots)
        check_episode_settings(horizon, control_freq)
        check_controller_configs(controller_configs)
        gripper_types = scene_gripper(self.robot_name, gripper_types)  # some arms get another gripper (robot configs)
        #: the configured task config; ``task_config`` is this episode's (randomised sizes, see randomization=)
        self.base_task_config = make_config(task_config)
        self.task_config = self.base_task_config
        #: the ranges drawn at every reset (:data:`~.randomization.OFF`: none)
        self.randomization: DynamicsRandomization = resolve_randomization(randomization)
        #: the values of this episode's draw (None while randomisation is off)
        self.dynamics_sample: DynamicsSample | None = None
        self._nominal_sim = None  # the simulation whose unrandomised values _nominal holds
        self._nominal: dict = {}
        self.task_spec: TaskSpec = get_task_spec(task)
        self.task_model = TaskModel(spec=self.task_spec)
        self.n_segments: int = self.task_spec.segments
        self.n_objects: int = self.task_spec.n_objects
        override = self.task_config["object_type"]
        #: the objects' registered types (ObjectType), object 1 first
        self.object_types = tuple(get_object_type(override or kind) for kind in self.task_spec.objects)
        self.geometry = scene_geometry(self.task_config, self.n_segments)  # ValueError naming the largest N
        check_objects_fit(self.object_types, self.geometry, self.task_config)
        self._check_randomization_fits()
        #: (M,) m footprints of the objects' geometry built from the unrandomised config: a drawn
        #: object_size_scale grows an overridden footprint by the ratio of the built one to these
        self._nominal_footprints = np.array(
            [type_geometry(kind, self.task_config).footprint_radius for kind in self.object_types], dtype=float)
        # 0-based internally (None: drawn at each reset); set through set_start() with 1-based numbers
        self.object_segment: int | None = None
        self.object_segments: tuple[int | None, ...] = (None,) * self.n_objects
        self.arm_segment: int | None = None
        self.dirty_segments: tuple[int, ...] = ()
        layout = (object_segment, arm_segment, dirty_segments, object_segments)
        if task is not None and all(value is FROM_SPEC for value in layout):
            self._start_from_spec()
        else:
            object_segment, arm_segment, dirty_segments, object_segments = (
                None if value is FROM_SPEC else value for value in layout)
            self.set_start(object_segment, arm_segment, dirty_segments, object_segments=object_segments)
        self.reward_scale = reward_scale
        self.reward_shaping = reward_shaping
        self.use_object_obs = use_object_obs
        marker_xy = marker_positions(self.task_config, self.n_segments)
        self._markers_per_segment = marker_xy.shape[1]
        self._marker_xyz = np.column_stack(
            [marker_xy.reshape(-1, 2), np.full(marker_xy.shape[0] * marker_xy.shape[1], self.geometry.table_top_z)]
        )
        self._n_task_states = self.task_model.n_states  # size of the symbolic_state_onehot observable
        self._shown_dirt: tuple | None = None  # the dirt-state joint positions the marker visuals show
        self._arm_qpos_cache: dict[tuple, np.ndarray] = {}
        # (object segment, arm segment) of this episode, 0-based; with M > 1 objects (object segments, arm segment)
        self.layout: tuple | None = None
        super().__init__(
            robots=robots,
            env_configuration=env_configuration,
            controller_configs=controller_configs,
            base_types=base_types,
            gripper_types=gripper_types,
            initialization_noise=initialization_noise,
            use_camera_obs=use_camera_obs,
            has_renderer=has_renderer,
            has_offscreen_renderer=has_offscreen_renderer,
            render_camera=render_camera,
            render_collision_mesh=render_collision_mesh,
            render_visual_mesh=render_visual_mesh,
            render_gpu_device_id=render_gpu_device_id,
            control_freq=control_freq,
            lite_physics=lite_physics,
            horizon=horizon,
            ignore_done=ignore_done,
            hard_reset=hard_reset,
            camera_names=camera_names,
            camera_heights=camera_heights,
            camera_widths=camera_widths,
            camera_depths=camera_depths,
            camera_segmentations=camera_segmentations,
            renderer=renderer,
            renderer_config=renderer_config,
            seed=seed,
        )
        self._check_holdable()

    # ------------------------------------------------------------------------------------------
    # robosuite hooks
    # ------------------------------------------------------------------------------------------
    def reward(self, action=None):
        """Reward function for the task (pure: reads the state, changes nothing).

        Sparse un-normalised reward:

            - a discrete reward of 3.0 on success (every segment clean, objects on the table, sponge home)

        Un-normalised components if using reward shaping (without success):

            - Wiping: in [0, 2], per segment min(1, wiped fraction / clean_fraction), averaged over the N segments, times 2
            - Object on the table: in {0, 0.25}, non-zero when every object lies on a segment (none held)
            - Sponge returned: in {0, 0.5}, non-zero when a segment is clean and the sponge is home

        The shaped total stays below the success reward (at most 2.75 < 3.0).  The final reward is
        scaled by reward_scale / 3.0 so that the maximum is reward_scale.

        Args:
            action (np.array): [NOT USED]

        Returns:
            float: reward value
        """
        reward = 0.0
        if self._check_success():
            reward = SUCCESS_REWARD
        elif self.reward_shaping:
            reward = sum(self.staged_rewards())
        if self.reward_scale is not None:
            reward *= self.reward_scale / SUCCESS_REWARD
        return reward

    def staged_rewards(self) -> tuple[float, float, float]:
        """Un-normalised shaping components ``(wiping, object_on_table, sponge_returned)`` (see :meth:`reward`)."""
        info = self.skill_info()
        wiped = 1.0 - info["dirt_fraction"]
        # scaled to the paper's two segments' range [0, 2] whatever N is, so the total stays below success
        per_segment = np.minimum(1.0, wiped / self.task_config["clean_fraction"])
        r_wipe = WIPE_REWARD_PER_SEGMENT * float(per_segment.mean()) * PAPER_REWARD_SEGMENTS
        try:
            on_table = HELD not in abstraction.object_locations(info, self.task_config)
        except abstraction.AbstractionError:
            on_table = False
        r_object = OBJECT_ON_TABLE_REWARD if on_table else 0.0
        clean = abstraction.segments_clean(info["dirt_fraction"], self.task_config)
        returned = bool(clean.any()) and abstraction.sponge_at_home(info, self.task_config)
        r_sponge = SPONGE_RETURNED_REWARD if returned else 0.0
        return r_wipe, r_object, r_sponge

    def _load_model(self):
        """Loads the arena (table, segments, dirt, stand), the Panda, the object and the sponge into self.model."""
        super()._load_model()
        if self.randomization.enabled and self.dynamics_sample is None:  # the constructor's scene
            self._draw_dynamics()
        config = self.task_config
        robot_model = self.robots[0].robot_model
        robot_model.set_base_xpos(np.add(robot_model.base_xpos_offset["table"](config["table_full_size"][0]),
                                          scene_base_shift(self.robot_name)))  # some arms sit closer (robot configs)
        exclude_parent_contacts(robot_model)  # a fixed base's first link must not collide with it (Sawyer)
        arena = TableCleanArena(
            geometry=self.geometry,
            marker_xy=self._marker_xyz[:, :2].reshape(self.n_segments, self._markers_per_segment, 2),
            marker_radius=config["marker_radius"],
            table_full_size=config["table_full_size"],
            table_friction=config["table_friction"],
            table_offset=config["table_offset"],
        )
        arena.set_origin([0, 0, 0])
        self.arena = arena
        #: the M task objects (robosuite MujocoObjects), object 1 first; ``self.object`` is object 1
        self.objects = [make_object(kind.name, self._object_build_config(j), name)
                        for j, (kind, name) in enumerate(zip(self.object_types, object_names(self.n_objects)))]
        self.object = self.objects[0]
        #: the objects' collision geometry in their own frames (read from MuJoCo, :mod:`.object_geometry`)
        self.object_geometries = tuple(object_geometry(o) for o in self.objects)
        self.sponge = make_sponge(config["sponge_half_size"], config["sponge_density"])
        self.model = ManipulationTask(
            mujoco_arena=arena,
            mujoco_robots=[robot.robot_model for robot in self.robots],
            mujoco_objects=[*self.objects, self.sponge],
        )

    def _setup_references(self):
        """Caches ids of the object, sponge, table top and dirt markers."""
        super()._setup_references()
        model = self.sim.model
        self._mj_data = mj_data(self.sim)
        self.object_body_ids = np.array([model.body_name2id(o.root_body) for o in self.objects])
        self.object_body_id = int(self.object_body_ids[0])
        self.sponge_body_id = model.body_name2id(self.sponge.root_body)
        gripper = self.robots[0].gripper[self.robots[0].arms[0]]

        def mask(names):
            return wiping.geom_mask(model.ngeom, [model.geom_name2id(n) for n in names])

        self._table_mask = mask([TABLE_TOP_GEOM])
        self._sponge_mask = mask(self.sponge.contact_geoms)
        self._object_masks = tuple(mask(o.contact_geoms) for o in self.objects)
        self._object_mask = self._object_masks[0]
        shapes = self.object_geometries
        self._object_rest_z = np.array([self.geometry.table_top_z - float(g.lower[2]) for g in shapes])
        self._object_half_sizes = np.array([g.half_size for g in shapes], dtype=float)
        # an overridden footprint grows with the drawn size as the geometry's does
        growth = np.array([g.footprint_radius for g in shapes]) / self._nominal_footprints
        self._object_footprints = np.array([footprint_radius(kind, g) for kind, g in zip(self.object_types, shapes)])
        self._object_footprints *= np.where([k.footprint_radius is None for k in self.object_types], 1.0, growth)
        #: (M,) each object's outline (K, 2) [m] seen from above in its own frame, upright: what the reset's
        #: grid places (placement.row_layout); layouts cached per (objects, segment, config)
        self._object_outlines = tuple(object_outline(kind, g, float(r)) for kind, g, r
                                      in zip(self.object_types, shapes, self._object_footprints))
        self._layout_cache: dict = {}
        self.gripper_geometry = measure_gripper(mj_model(self.sim), self._mj_data.qpos.copy(), gripper,
                                                gripper.important_sites["grip_site"])
        self._finger_pad_masks = (
            mask(gripper.important_geoms["left_fingerpad"]),
            mask(gripper.important_geoms["right_fingerpad"]),
        )
        self.marker_geom_ids = np.array([model.geom_name2id(n) for n in self.arena.marker_names])
        self._dirt_joints = tuple(self.arena.dirt_state_joint_names)  # one per segment
        self._dirt_qpos_addr = tuple(int(model.get_joint_qpos_addr(j)) for j in self._dirt_joints)
        self._dirt_qpos_index = np.array(self._dirt_qpos_addr, dtype=np.intp)  # gathers them in one call
        self._dirt_qvel_addr = tuple(int(model.get_joint_qvel_addr(j)) for j in self._dirt_joints)
        self._qpos_cache = None  # _qpos_view()'s and _dirt_positions()' views of the (new) data
        self._shown_dirt = None  # a new model shows every marker: synchronise at the next chance
        self._present_cache: tuple | None = None  # (dirt-state joint positions, decoded present mask)
        self._fraction_cache: tuple | None = None  # (dirt-state joint positions, dirt_fraction())
        self._constant_info: tuple | None = None  # (simulation data, config, geometry, skill_info's constants)
        self._views: tuple | None = None  # _data_views() of this simulation's data
        self._grasp_groups = None  # _grasped_bodies' and sponge_press_force's lookups follow the masks above
        self._press_native = None
        if self.sim is not self._nominal_sim:  # a new model: remember its unrandomised values
            self._nominal_sim = self.sim
            self._nominal = self._read_nominal()

    def _setup_observables(self):
        """Object, sponge, dirt and symbolic-state observables on top of the robot's proprioception.

        Returns:
            OrderedDict: observable name -> :class:`Observable`
        """
        observables = super()._setup_observables()
        if not self.use_object_obs:
            return observables
        modality = "object"

        @sensor(modality=modality)
        def object_pos(obs_cache):
            return np.array(self.sim.data.body_xpos[self.object_body_id])

        @sensor(modality=modality)
        def object_quat(obs_cache):
            return convert_quat(np.array(self.sim.data.body_xquat[self.object_body_id]), to="xyzw")

        @sensor(modality=modality)
        def sponge_pos(obs_cache):
            return np.array(self.sim.data.body_xpos[self.sponge_body_id])

        @sensor(modality=modality)
        def sponge_quat(obs_cache):
            return convert_quat(np.array(self.sim.data.body_xquat[self.sponge_body_id]), to="xyzw")

        @sensor(modality=modality)
        def dirt_fraction(obs_cache):
            return self.dirt_fraction()

        @sensor(modality=modality)
        def symbolic_state_index(obs_cache):
            return self._symbolic_index()

        @sensor(modality=modality)
        def symbolic_state_onehot(obs_cache):
            cached = obs_cache.get("symbolic_state_index")
            index = self._symbolic_index() if cached is None else int(cached)
            onehot = np.zeros(self._n_task_states)
            if index != FAULT_INDEX:
                onehot[index] = 1.0
            return onehot

        sensors = [object_pos, object_quat, sponge_pos, sponge_quat, dirt_fraction]
        if self.n_objects > 1:

            @sensor(modality=modality)
            def objects_pos(obs_cache):
                return np.array(self.sim.data.body_xpos[self.object_body_ids]).ravel()

            @sensor(modality=modality)
            def objects_quat(obs_cache):
                quats = np.array(self.sim.data.body_xquat[self.object_body_ids])
                return np.concatenate([convert_quat(q, to="xyzw") for q in quats])

            sensors += [objects_pos, objects_quat]
        arm_prefixes = self._get_arm_prefixes(self.robots[0], include_robot_name=False)
        full_prefixes = self._get_arm_prefixes(self.robots[0])
        sensors += [
            self._get_obj_eef_sensor(full_pf, "object_pos", f"{arm_pf}gripper_to_object_pos", modality)
            for arm_pf, full_pf in zip(arm_prefixes, full_prefixes)
        ]
        sensors += [symbolic_state_index, symbolic_state_onehot]
        for s in sensors:
            observables[s.__name__] = Observable(name=s.__name__, sensor=s, sampling_rate=self.control_freq)
        return observables

    def _reset_internal(self):
        """Draws the layout, puts the arm over its segment, places objects and sponge, lays out the dirt."""
        self._state_epoch += 1
        objects, arm_segment = self._draw_layout()
        self.layout = (objects[0] if self.n_objects == 1 else objects, arm_segment)
        self.robots[0].init_qpos = self._arm_reset_qpos(arm_segment)
        super()._reset_internal()
        if self.dynamics_sample is not None:
            self._apply_dynamics(self.dynamics_sample)
        if not self.deterministic_reset:
            self._place_objects(objects)
            self._place_sponge()
        dirty = np.zeros(len(self._marker_xyz), dtype=bool)
        for segment in self.dirty_segments:
            self._segment_slice_view(dirty, segment)[:] = True
        self._write_marker_present(dirty)
        self.show_dirt()

    def reset(self):
        """robosuite's reset, after drawing this episode's randomised dynamics (when ``randomization`` is on).

        A draw that changes a size rebuilds the MuJoCo model first, also with ``hard_reset=False``.
        """
        if not (self.randomization.enabled and not self.deterministic_reset):
            return super().reset()
        built = self._built_sizes()
        self._draw_dynamics()
        hard_reset = self.hard_reset
        # robosuite's own hard reset rebuilds the model and re-binds the observables' sensors
        # (the idiom of robosuite's VisualizationWrapper)
        self.hard_reset = hard_reset or self._built_sizes() != built
        try:
            return super().reset()
        finally:
            self.hard_reset = hard_reset

    def step(self, action):
        """robosuite's step, after refusing an action that is not all finite numbers: ``ValueError``
        naming the bad entries (NaN or Inf would reach the controller and the simulation)."""
        check_finite_action(action)
        return super().step(action)

    def _pre_action(self, action, policy_step=False):
        """Robot control (superclass), then records wiping on the state after the previous substep."""
        super()._pre_action(action, policy_step)
        self.record_wiping_substep()

    def _post_action(self, action):
        """Hides the markers wiped during this control step, then reward / done (superclass)."""
        self.show_dirt()
        return super()._post_action(action)

    def _get_observations(self, force_update=False):
        """The markers' visuals follow the dirt state first (it may have been restored), then the observations."""
        self.show_dirt()
        return super()._get_observations(force_update)

    def render(self):
        """The markers' visuals follow the dirt state first (it may have been restored), then robosuite's render."""
        self.show_dirt()
        return super().render()

    def _check_success(self):
        """Every segment clean, every object lying on a segment, the sponge at home.

        Returns:
            bool: True if the task is solved
        """
        if not abstraction.segments_clean(self.dirt_fraction(), self.task_config).all():
            return False
        info = self.skill_info()
        try:
            on_table = HELD not in abstraction.object_locations(info, self.task_config)
        except abstraction.AbstractionError:
            return False
        return on_table and abstraction.sponge_at_home(info, self.task_config)

    # ------------------------------------------------------------------------------------------
    # public API for skills and learners
    # ------------------------------------------------------------------------------------------
    def set_start(self, object_segment: int | None, arm_segment: int | None,
                  dirty_segments: Iterable[int] | None = None, *,
                  object_segments: Iterable[int | None] | None = None) -> None:
        """The layout of the following resets, as the constructor's arguments (1-based segment numbers).

        Args:
            object_segment: segment every object starts on (1..N) or None (each drawn at each reset).
            arm_segment: segment the arm starts above (1..N) or None (drawn at each reset).
            dirty_segments: segments that start dirty (each 1..N); None: all.
            object_segments: M entries (1..N or None), one per object; overrides ``object_segment``.

        Raises ``ValueError`` naming the bad value and the allowed ones; nothing changes then.
        Stored 0-based in ``object_segment``, ``object_segments``, ``arm_segment`` and ``dirty_segments``.
        """
        n = self.n_segments
        single = _segment_option("object_segment", object_segment, n)
        if object_segments is None:
            per_object = (single,) * self.n_objects
        else:
            try:
                entries = tuple(object_segments)
            except TypeError:
                raise ValueError(f"object_segments must be {self.n_objects} segment numbers, got {object_segments!r}") from None
            if len(entries) != self.n_objects:
                raise ValueError(f"object_segments must have one entry per object ({self.n_objects}), got {object_segments!r}")
            per_object = tuple(_segment_option(f"object_segments[{j}]", v, n) for j, v in enumerate(entries))
        layout = (
            single if object_segments is None else (per_object[0] if len(set(per_object)) == 1 else None),
            per_object,
            _segment_option("arm_segment", arm_segment, n),
            _dirty_option(dirty_segments, n),
        )
        self.object_segment, self.object_segments, self.arm_segment, self.dirty_segments = layout

    def set_start_state(self, state: TaskState) -> None:
        """The following resets start in the task state ``state`` (objects lying, none held).

        A held object is staged by resetting with it on the arm's segment and picking it
        (:func:`tableclean_suite.physics_backend.stage`).  Raises ``ValueError`` for a state of
        another size or one holding an object.
        """
        state = self.task_model.as_state(state)
        if state.holding:
            raise ValueError(f"set_start_state takes states with every object lying; {state.name} holds one "
                             "(tableclean_suite.physics_backend.stage picks it up after a reset)")
        self.set_start(None, state.arm + 1, [k + 1 for k in range(state.n_segments) if not state.is_clean(k)],
                       object_segments=[where + 1 for where in state.objects])

    def _start_from_spec(self) -> None:
        """The layout of the spec's start: its fixed ``start_state``, or every layout drawn at each reset."""
        if self.task_model.start != StartMode.FIXED:  # uniform_unclean: all dirty, each position drawn uniformly
            self.set_start(None, None, None)
            return
        state = self.task_model.start_state
        if state.holding:
            raise ValueError(f"task {self.task_spec.name!r} starts in {state.name}, which holds an object; TableClean "
                             "resets with every object lying: pass a layout (object_segment=..., arm_segment=...) "
                             "and stage the held start with tableclean_suite.physics_backend.stage")
        self.set_start_state(state)

    def put_object(self, obj: int, segment: int) -> None:
        """Teleport object ``obj`` (0-based), at rest, onto a free spot of ``segment`` (0-based).

        The spot is :func:`.placement.free_spot` among the objects lying there (as the place
        skill chooses it).  Used by staging; the physics is forwarded, not stepped.
        """
        info = self.skill_info()
        others = [(info["objects_pos"][k], placement.footprint_of(info, k)) for k in range(self.n_objects)
                  if k != obj and self._lies_on(info, k, segment)]
        xy = placement.free_spot(self.geometry.segment_centers[segment], self.geometry.segment_half_sizes[segment],
                                 self._object_outlines[obj], others, self.task_config["object_clearance"],
                                 placement.other_segments(self.geometry.segment_centers,
                                                          self.geometry.segment_half_sizes, segment))
        self._set_object_pose(obj, xy, 0.0)
        self.sim.forward()

    def _lies_on(self, info: Mapping, obj: int, segment: int) -> bool:
        pos = info["objects_pos"][obj]
        near_rest = pos[2] <= info["objects_rest_z"][obj] + self.task_config["lift_tolerance"]
        return near_rest and self.segment_of_position(pos) == segment

    def dirt_fraction(self) -> np.ndarray:
        """Shape (N,): fraction of each segment's dirt markers still present (1.0 = all dirty), read from qpos.

        Raises :class:`~tableclean_suite.environments.dirt_state.DirtStateError` when a dirt-state
        joint holds no valid code (e.g. a state from another model was restored).
        """
        k = self._markers_per_segment
        positions = self._dirt_positions()
        if self._fraction_cache is None or self._fraction_cache[0] != positions:
            wiped = [dirt_state.wiped_count(x, k, j) for x, j in zip(positions, self._dirt_joints)]
            self._fraction_cache = (positions, (k - np.array(wiped, dtype=float)) / k)
        return self._fraction_cache[1].copy()

    def skill_info(self) -> SkillInfo:
        """Grounding for skills and the abstraction (world frame, metres, quaternions xyzw).

        Keys: ``eef_pos`` (3,), ``eef_quat`` (4,), ``eef_rot`` (3, 3) the grip site's rotation matrix (the
        matrix ``eef_quat`` is converted from), ``gripper_qpos`` (2,), ``object_pos`` (3,),
        ``object_quat`` (4,), ``object_half_size`` (3,) bounding half extents, ``object_rest_z``
        object centre height when resting on the table (these four: object 1), ``objects_pos``
        (M, 3), ``objects_quat`` (M, 4), ``objects_half_size`` (M, 3), ``objects_rest_z`` (M,),
        ``objects_grasped`` (M,) bool, ``object_types`` (M,) the objects'
        :class:`~tableclean_suite.environments.objects.ObjectType` (overrides), ``objects_geometry``
        (M,) their :class:`~.object_geometry.ObjectGeometry` (collision extent in their own frames),
        ``objects_footprint`` (M,) m footprint radii, ``gripper_open_width`` m (open pad gap) and
        ``gripper_palm_height`` m (hand's lowest point above the grip site) and ``gripper_hand_reach`` m
        (how far the hand reaches sideways from the grip site, :mod:`.gripper_geometry`),
        ``gripper_hand_half_width`` m (how far it reaches across the fingers' closing axis),
        ``sponge_pos`` (3,), ``sponge_quat`` (4,), ``sponge_half_size`` (3,), ``sponge_home_pos`` (3,),
        ``segment_centers`` (N, 3) table-top point at each segment centre (row 0 = segment 1),
        ``segment_half_sizes`` (N, 2), ``table_top_z`` float, ``table_center`` (3,),
        ``table_half_size`` (2,), ``robot_base_pos`` (3,) the arm's base (its root body), ``object_grasped``
        (object 1) and ``sponge_grasped`` bool (both finger pads touch it), ``dirt_fraction`` (N,),
        ``qvel`` (nv,) all simulation velocities,
        ``object_spacing`` (the config's reset-grid pitch) and ``object_clearance`` (the config's,
        for the place skill's free spot).

        Read every control step by the skills, so it does little: a :class:`~.skill_info.SkillInfo`
        (a dict) whose values fixed for the model and the episode (sizes, geometry, measures,
        config values) are shared read-only arrays, and whose costlier per-step values (the keys of
        :data:`LAZY_SKILL_INFO`: object 1's pose, orientations, grasp flags, sponge pose, dirt, velocities) are
        computed on first read, from the simulation state of the call.
        """
        data = self._mj_data
        views = self._views
        if views is None or views.data is not data:
            views = self._data_views()
        constant = self._constant_info
        if constant is None or constant[0] is not data or constant[1] is not self.task_config or constant[2] is not self.geometry:
            values = self._constant_skill_info()
        else:
            values = constant[3]  # (the checks of _constant_skill_info inline: read every control step)
        info = SkillInfo.create(values, self, LAZY_SKILL_INFO, self._sim_time, (self._state_epoch, data.time))
        info["eef_pos"] = views.eef_pos.copy()
        info["gripper_qpos"] = views.qpos[views.fingers]  # fancy indexing copies
        info["objects_pos"] = views.xpos[views.objects_pos]
        return info

    _qpos_cache: tuple | None = None  # (data, its qpos view, the dirt-state joints' qpos as a view or None)

    def _qpos_view(self) -> np.ndarray:
        """The simulation data's ``qpos``, kept per data (each mjData attribute access builds a new view, ~0.3 us;
        the buffer stays put while the data lives)."""
        return self._qpos_entry()[1]

    def _qpos_entry(self) -> tuple:
        """``(data, its qpos view, the dirt-state joints' positions as a strided view or None)``, kept per
        simulation data: when the dirt-state joints' addresses are evenly spaced (one slide joint per
        segment, usually adjacent), a strided view of their positions."""
        data = self._mj_data
        cached = self._qpos_cache
        if cached is not None and cached[0] is data:
            return cached
        qpos = data.qpos
        addr = getattr(self, "_dirt_qpos_addr", ())  # (set when the model loads; the cache is dropped then)
        dirt = None
        stride = addr[1] - addr[0] if len(addr) > 1 else 1
        if addr and stride > 0 and all(b - a == stride for a, b in zip(addr, addr[1:])):
            dirt = qpos[addr[0]:addr[-1] + 1:stride]
        self._qpos_cache = (data, qpos, dirt)
        return self._qpos_cache

    def _dirt_positions(self) -> tuple:
        """The dirt-state joints' positions, a tuple of Python floats (the key of the dirt-state caches; read
        at every control step and wiping check: one kept view's ``tolist`` where possible)."""
        cached = self._qpos_entry()
        dirt = cached[2]
        if dirt is None:
            return tuple(cached[1][self._dirt_qpos_index].tolist())
        return tuple(dirt.tolist())

    def _data_views(self) -> _DataViews:
        """Views into the simulation data and the indexes :meth:`skill_info` reads every control step, kept
        per simulation data (its buffers stay put while it lives; each mjData attribute access builds a new
        array view, ~0.3 us, and the objects' rows gathered by one precomputed index cost ~0.1 us where
        row indexing and reordering the quaternions took ~3 us)."""
        data = self._mj_data
        cached = self._views
        if cached is None or cached.data is not data:
            robot = self.robots[0]
            arm = robot.arms[0]
            objects = np.asarray(self.object_body_ids, dtype=np.intp)[:, None]
            sponge = np.intp(self.sponge_body_id)
            cached = self._views = _DataViews(
                data=data, eef_pos=data.site_xpos[robot.eef_site_id[arm]],
                eef_xmat=data.site_xmat[robot.eef_site_id[arm]], qpos=data.qpos,
                fingers=self._finger_qpos_index(robot, arm), xpos=data.xpos.reshape(-1), xquat=data.xquat.reshape(-1),
                objects_pos=objects * 3 + np.arange(3), objects_quat=objects * 4 + XYZW_FROM_WXYZ,
                sponge_pos=sponge * 3 + np.arange(3), sponge_quat=sponge * 4 + XYZW_FROM_WXYZ)
        return cached

    #: Counts the writes of the scene's state that need not move the clock (a reset, :meth:`set_scene_state`,
    #: an object put down by hand): with the simulation time, the stamp of a :meth:`skill_info`.
    _state_epoch = 0

    def _sim_time(self) -> tuple[int, float]:
        """``(state writes, simulation time [s])``: the stamp of a :meth:`skill_info` (its lazy keys are read
        only while both are unchanged)."""
        return self._state_epoch, self._mj_data.time

    def _constant_skill_info(self) -> dict:
        """The :meth:`skill_info` values fixed while the model, the episode's config and geometry stay: read-only
        arrays, built once per model / config / geometry (a randomised reset draws a new config and geometry)."""
        cached = self._constant_info
        if (cached is not None and cached[0] is self._mj_data and cached[1] is self.task_config
                and cached[2] is self.geometry):
            return cached[3]
        geometry = self.geometry

        def frozen(values) -> np.ndarray:
            array = np.array(values, dtype=float)
            array.setflags(write=False)
            return array

        values = {
            "object_half_size": frozen(self._object_half_sizes[0]),
            "object_rest_z": float(self._object_rest_z[0]),
            "objects_half_size": frozen(self._object_half_sizes),
            "objects_rest_z": frozen(self._object_rest_z),
            "object_types": self.object_types,
            "objects_geometry": self.object_geometries,
            "objects_footprint": frozen(self._object_footprints),
            "gripper_open_width": self.gripper_geometry.open_width,
            "gripper_palm_height": self.gripper_geometry.palm_height,
            "gripper_hand_reach": self.gripper_geometry.hand_reach,
            "gripper_hand_half_width": self.gripper_geometry.hand_half_width,
            "object_spacing": float(self.task_config["object_spacing"]),
            "object_clearance": float(self.task_config["object_clearance"]),
            "sponge_half_size": frozen(self.sponge.get_bounding_box_half_size()),
            "sponge_home_pos": frozen(geometry.sponge_home_pos),
            "segment_centers": frozen(geometry.segment_centers),
            "segment_half_sizes": frozen(geometry.segment_half_sizes),
            "table_top_z": geometry.table_top_z,
            "table_center": frozen(geometry.table_center),
            "table_half_size": frozen(geometry.table_half_size),
            "robot_base_pos": frozen(self._mj_data.xpos[mj_model(self.sim).body(self.robots[0].robot_model.root_body).id]),
        }
        self._constant_info = (self._mj_data, self.task_config, self.geometry, values)
        return values

    # the lazy keys of skill_info (LAZY_SKILL_INFO): each computes its group on the first read
    def _info_eef_quat(self, info: SkillInfo) -> None:
        info["eef_quat"] = mat2quat(np.array(self._data_views().eef_xmat).reshape(3, 3)).astype(float)

    def _info_eef_rot(self, info: SkillInfo) -> None:
        info["eef_rot"] = np.array(self._data_views().eef_xmat).reshape(3, 3)

    def _info_object_pos(self, info: SkillInfo) -> None:
        views = self._data_views()
        info["object_pos"] = views.xpos[views.objects_pos[0]]  # objects_pos' first row (fancy indexing copies)

    def _info_objects_quat(self, info: SkillInfo) -> None:
        views = self._data_views()
        info["objects_quat"] = views.xquat[views.objects_quat]  # xyzw rows (XYZW_FROM_WXYZ)

    def _info_object_quat(self, info: SkillInfo) -> None:
        views = self._data_views()
        info["object_quat"] = views.xquat[views.objects_quat[0]]  # objects_quat' first row (a copy)

    def _info_grasped(self, info: SkillInfo) -> None:
        grasped = self._grasped_bodies()
        info["objects_grasped"] = grasped[:-1]
        flags = grasped.tolist()  # Python bools, as bool() of the entries
        info["object_grasped"] = flags[0]
        info["sponge_grasped"] = flags[-1]

    def _info_sponge(self, info: SkillInfo) -> None:
        views = self._data_views()
        info["sponge_pos"] = views.xpos[views.sponge_pos]
        info["sponge_quat"] = views.xquat[views.sponge_quat]  # xyzw (XYZW_FROM_WXYZ)

    def _info_dirt(self, info: SkillInfo) -> None:
        info["dirt_fraction"] = self.dirt_fraction()

    def _info_qvel(self, info: SkillInfo) -> None:
        info["qvel"] = np.array(self._mj_data.qvel)

    def _finger_qpos_index(self, robot, arm) -> np.ndarray:
        """qpos indexes (int array) of ``robot``'s finger joints on ``arm``, kept per robot and simulation (read
        every control step; a hard reset builds a new simulation, whose layout may differ)."""
        cached = getattr(self, "_finger_index_cache", None)
        if cached is None or cached[0] is not robot or cached[1] != arm or cached[2] is not self.sim:
            index = np.asarray(gripper_joint_pos_indexes(robot, arm), dtype=int)
            cached = self._finger_index_cache = (robot, arm, self.sim, index)
        return cached[3]

    _grasp_groups: tuple | None = None  # _grasped_bodies' lookup, per model (dropped when the masks are rebuilt)

    def _grasped_bodies(self) -> np.ndarray:
        """Bool (M + 1,) (a new array): for each object, then the sponge, whether both finger pads touch it.

        :meth:`_grasped` for all of them in one compiled pass over the contacts (:meth:`skill_info`
        asks every control step), each contact's geoms looked up in one table: their pad bits and the
        body they belong to (:func:`~.contact_kernels.grasped_bodies`).
        """
        cached = self._grasp_groups  # (lookup, bodies); None: the masks changed
        if cached is None:
            cached = self._grasp_groups = self._grasp_lookup()
        # the ncon active contacts (none: an empty view, no body grasped); no ncon read first: each binding call costs
        # ~2 us right after the physics left the CPU caches cold
        return grasped_bodies(self._mj_data.contact.geom, *cached)

    def _grasp_lookup(self) -> tuple:
        """``(lookup, bodies)``: :meth:`_grasped_bodies`' (ngeom, 2) int64 lookup of each geom's pad bits and body
        (object 0 .. M - 1, the sponge M, -1 for neither), and the number of bodies, M + 1."""
        objects, sponge, pads = self._object_masks, self._sponge_mask, self._finger_pad_masks
        lookup = np.zeros((sponge.size, 2), dtype=np.int64)
        lookup[:, LOOKUP_BODY] = -1
        for j, mask in enumerate(objects):
            lookup[mask, LOOKUP_BODY] = j
        lookup[sponge, LOOKUP_BODY] = len(objects)
        lookup[pads[0], LOOKUP_PADS] |= PAD_A
        lookup[pads[1], LOOKUP_PADS] |= PAD_B
        return lookup, len(objects) + 1

    def symbolic_state(self, check_sponge: bool = True) -> TaskState:
        """The current :class:`TaskState` read from the physics.

        Args:
            check_sponge: require the sponge at home (pass False while a skill carries it).

        Raises:
            AbstractionError: when the physical state maps to no task state (``.fault`` names it).
        """
        return abstraction.abstract_state(self.skill_info(), self.task_config, check_sponge=check_sponge)

    def segment_of_position(self, xy) -> int | None:
        """The segment whose cleanable area contains world ``xy`` (first two entries used), else None."""
        return abstraction.segment_of_xy(xy, self.geometry.segment_centers, self.geometry.segment_half_sizes)

    def get_scene_state(self) -> SceneState:
        """A copy of everything needed to put the scene back later (see :class:`SceneState`).

        Used to branch several actions from one reached state without replaying the plan.
        """
        data = mj_data(self.sim)
        return SceneState(
            time=float(data.time),
            qpos=data.qpos.copy(),
            qvel=data.qvel.copy(),
            act=data.act.copy(),
            ctrl=data.ctrl.copy(),
            qacc_warmstart=data.qacc_warmstart.copy(),
            gripper_commands=tuple(
                np.array(gripper.current_action, copy=True) for robot in self.robots for gripper in robot.gripper.values()
            ),
        )

    def set_scene_state(self, state: SceneState) -> None:
        """Put the scene back into ``state`` (from :meth:`get_scene_state` of this env)."""
        data = mj_data(self.sim)
        if state.qpos.shape != data.qpos.shape:
            raise ValueError(f"scene state comes from a different TableClean model: qpos has shape {state.qpos.shape}, "
                             f"this model's {data.qpos.shape}")
        self._state_epoch += 1
        data.time = state.time
        data.qpos[:] = state.qpos
        data.qvel[:] = state.qvel
        data.act[:] = state.act
        data.ctrl[:] = state.ctrl
        data.qacc_warmstart[:] = state.qacc_warmstart
        grippers = [gripper for robot in self.robots for gripper in robot.gripper.values()]
        for gripper, command in zip(grippers, state.gripper_commands):
            gripper.current_action = np.array(command, copy=True)
        self.show_dirt()
        self.sim.forward()

    def marker_present(self) -> np.ndarray:
        """Bool (N, markers_per_segment): the dirt markers still present (not wiped), read from qpos (a copy)."""
        return self._marker_present().reshape(self.n_segments, self._markers_per_segment).copy()

    def get_ep_meta(self) -> dict:
        """robosuite's episode metadata plus what the recorded episode is an instance of (JSON-serialisable).

        Keys added: ``task_spec`` (the task specification this scene builds, as
        ``TaskSpec.to_dict()``), ``object_types`` (the built types' names), ``task_config`` (the
        full physical config) and ``start`` (``object_segment``, ``arm_segment``, ``dirty_segments``
        and, with M > 1 objects, ``object_segments``, as 1-based numbers; None: drawn at each reset).
        ``DataCollectionWrapper`` stores it as ``ep_meta.json``.
        """
        meta = super().get_ep_meta()

        def number(segment):
            return None if segment is None else segment + 1

        meta.update(
            task_spec=self.task_spec.to_dict(),
            object_types=[kind.name for kind in self.object_types],
            task_config=_jsonable(self.task_config),
            start={
                "object_segment": number(self.object_segment),
                "arm_segment": number(self.arm_segment),
                "dirty_segments": [k + 1 for k in self.dirty_segments],
            },
        )
        if self.n_objects > 1:  # one entry per object (the paper scene's meta keeps its v1 keys)
            meta["start"]["object_segments"] = [number(k) for k in self.object_segments]
        if self.randomization.enabled:  # the unrandomised scene's meta keeps its v2 keys
            meta["randomization"] = self.randomization.to_dict()
            meta["dynamics_sample"] = None if self.dynamics_sample is None else self.dynamics_sample.to_dict()
        return meta

    # ------------------------------------------------------------------------------------------
    # internals
    # ------------------------------------------------------------------------------------------
    def _marker_present(self) -> np.ndarray:
        """Bool (N * markers_per_segment,), read-only: markers not wiped, decoded from the dirt-state joints' qpos.

        The decoded mask is cached per joint positions: the wiping check asks at every substep.
        """
        k = self._markers_per_segment
        positions = self._dirt_positions()
        if self._present_cache is None or self._present_cache[0] != positions:
            wiped = [dirt_state.decode(x, k, j) for x, j in zip(positions, self._dirt_joints)]
            present = ~np.concatenate(wiped)
            present.flags.writeable = False
            self._present_cache = (positions, present)
        return self._present_cache[1]

    def _write_marker_present(self, present: np.ndarray) -> None:
        """Record bool (N * markers_per_segment,) ``present`` in the dirt-state joints (qpos; velocities zeroed)."""
        data = self._mj_data
        per_segment = np.asarray(present, dtype=bool).reshape(self.n_segments, self._markers_per_segment)
        for qpos_addr, qvel_addr, flags in zip(self._dirt_qpos_addr, self._dirt_qvel_addr, per_segment):
            data.qpos[qpos_addr] = dirt_state.encode(~flags)
            data.qvel[qvel_addr] = 0.0

    def _segment_slice_view(self, flat: np.ndarray, segment: int) -> np.ndarray:
        return flat.reshape(self.n_segments, self._markers_per_segment)[segment]

    def _draw_layout(self) -> tuple[tuple[int, ...], int]:
        """(object segments (M,), arm segment): the configured ones, or drawn from ``self.rng`` when None."""
        # always drawn (objects, then the arm), so the rng stream is layout-independent; for the paper's
        # N = 2, M = 1 this is the v1 draw of (object, arm)
        draws = self.rng.integers(0, self.n_segments, size=self.n_objects + 1)
        objects = tuple(int(d) if k is None else k for k, d in zip(self.object_segments, draws[:-1]))
        arm = self.arm_segment if self.arm_segment is not None else int(draws[-1])
        return objects, arm

    def _arm_reset_qpos(self, segment: int) -> np.ndarray:
        """Joint positions putting the gripper site ``arm_hover_height`` above ``segment``'s centre, or
        :data:`RESET_OBJECT_CLEARANCE` above the tallest object's top when that is higher (cached)."""
        tallest = max(float(g.height) for g in self.object_geometries)
        height = max(float(self.task_config["arm_hover_height"]), tallest + RESET_OBJECT_CLEARANCE)
        key = (segment, height)
        if key not in self._arm_qpos_cache:
            robot = self.robots[0]
            model = self.sim.model
            qpos_addrs = [model.get_joint_qpos_addr(j) for j in robot.robot_model.joints]
            dof_addrs = [model.get_joint_qvel_addr(j) for j in robot.robot_model.joints]
            site_id = model.site_name2id(robot.gripper[robot.arms[0]].important_sites["grip_site"])
            q_default = np.array(robot.robot_model.init_qpos, dtype=float)
            _, default_mat = site_pose(mj_model(self.sim), qpos_addrs, site_id, q_default)
            target = self.geometry.segment_centers[segment] + [0.0, 0.0, height]
            self._arm_qpos_cache[key] = solve_site_pose(
                mj_model(self.sim), qpos_addrs, dof_addrs, site_id, target, default_mat, q_default
            )
        return self._arm_qpos_cache[key].copy()

    def _place_objects(self, segments: tuple[int, ...]) -> None:
        """Put object j on ``segments[j]`` (0-based) following :mod:`.placement` (a grid of oriented footprints
        plus capped xy and yaw noise, :meth:`_row_layout`).

        Raises ``ValueError`` when the objects sharing a segment do not fit on it.
        """
        config = self.task_config
        for segment in sorted(set(segments)):
            here = tuple(j for j, k in enumerate(segments) if k == segment)
            layout = self._row_layout(here, segment)
            yaw_noise = float(config["placement_yaw_noise"])
            for j, offset, bound, base_yaw in zip(here, layout.offsets, layout.xy_noise, layout.yaws):
                # the draws of the v1 scene for one object: xy noise, then yaw noise
                noise = self.rng.uniform(-config["placement_noise"], config["placement_noise"], size=2)
                noise = np.clip(noise, -bound, bound)
                yaw = self.rng.uniform(-yaw_noise, yaw_noise)
                if layout.yaw_noise < yaw_noise:
                    yaw = float(np.clip(yaw, -layout.yaw_noise, layout.yaw_noise))
                if base_yaw != 0.0:
                    yaw = float(base_yaw) + yaw
                self._set_object_pose(j, self.geometry.segment_centers[segment, :2] + offset + noise, yaw)

    def _row_layout(self, here: tuple[int, ...], segment: int) -> placement.RowLayout:
        """The :func:`.placement.row_layout` of objects ``here`` (0-based) on ``segment`` (0-based), cached per
        model and config values; ``ValueError`` naming the objects when they do not fit."""
        config = self.task_config
        half = self.geometry.segment_half_sizes[segment]
        key = (here, tuple(half), float(config["object_spacing"]), float(config["object_clearance"]),
               float(config["placement_noise"]), float(config["placement_yaw_noise"]))
        if key not in self._layout_cache:
            try:
                self._layout_cache[key] = placement.row_layout(
                    [self._object_outlines[j] for j in here], half, key[2], key[3], key[4], key[5])
            except placement.DoesNotFit as error:
                raise ValueError(f"objects {[j + 1 for j in here]} do not fit side by side on segment {segment + 1}: "
                                 f"{error}") from None
        return self._layout_cache[key]

    def _set_object_pose(self, obj: int, xy, yaw: float) -> None:
        """Object ``obj`` at rest on the table at world ``xy`` with ``yaw`` [rad] (qpos set, qvel zeroed)."""
        self._state_epoch += 1
        z = self.geometry.table_top_z - float(self.object_geometries[obj].lower[2]) + PLACEMENT_CLEARANCE
        quat_wxyz = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        joint = self.objects[obj].joints[0]
        self.sim.data.set_joint_qpos(joint, np.concatenate([np.asarray(xy, dtype=float)[:2], [z], quat_wxyz]))
        self.sim.data.set_joint_qvel(joint, np.zeros(6))

    def _place_sponge(self) -> None:
        """The sponge at rest on its home, offset and turned by this episode's draw (if randomised)."""
        pos, yaw = self.geometry.sponge_home_pos.copy(), 0.0
        if self.dynamics_sample is not None:
            yaw = self.dynamics_sample.sponge_yaw
            # clipped so the turned sponge rests wholly on its stand, STAND_EDGE_MARGIN inside its edges
            # (MuJoCo's box-box test reports a bogus deep contact when the two boxes' edges coincide)
            half = np.asarray(self.task_config["sponge_half_size"], dtype=float)
            footprint = np.abs(np.cos(yaw)) * half[:2] + np.abs(np.sin(yaw)) * half[1::-1]
            room = np.maximum(self.geometry.stand_half_size[:2] - footprint - STAND_EDGE_MARGIN, 0.0)
            pos[:2] += np.clip(self.dynamics_sample.sponge_home_offset, -room, room)
            # and it settles from just above, as the objects do: a turned box resting exactly on another
            # can also get a bogus deep contact from MuJoCo's box-box test
            pos[2] += PLACEMENT_CLEARANCE
        quat_wxyz = [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)]
        self.sim.data.set_joint_qpos(self.sponge.joints[0], np.concatenate([pos, quat_wxyz]))

    # -- randomised dynamics (see tableclean_suite.environments.randomization) -------------------
    def _check_holdable(self) -> None:
        """``ValueError`` (the scene closed) naming an object whose narrowest width the open gripper cannot take."""
        try:
            for kind, shape in zip(self.object_types, self.object_geometries):
                check_holdable(kind, shape, self.gripper_geometry.open_width, f"{self.robot_name} gripper")
        except ValueError:
            self.close()
            raise

    def _check_randomization_fits(self) -> None:
        """``ValueError`` when the randomisation could move the sponge's start out of its home tolerance,
        or draw objects too large to fit side by side on one segment."""
        largest = self.randomization.object_size_scale[1]
        if largest > 1.0:
            check_objects_fit(self.object_types, self.geometry, self.task_config, largest)
        corner = self.randomization.sponge_home_noise * np.sqrt(2.0)
        if corner > self.base_task_config["sponge_home_tolerance"]:
            raise ValueError(f"randomization sponge_home_noise {self.randomization.sponge_home_noise} m can put the "
                             f"sponge {corner:.4f} m from home, beyond sponge_home_tolerance "
                             f"{self.base_task_config['sponge_home_tolerance']} m")

    def _draw_dynamics(self) -> None:
        """Draw this episode's :class:`DynamicsSample` from ``self.rng``; the episode's config and geometry follow."""
        n_joints = len(self.robots[0].robot_model.joints)
        sample = self.randomization.sample(self.rng, self.n_objects, n_joints)
        self.dynamics_sample = sample
        base = self.base_task_config
        sponge = np.asarray(base["sponge_half_size"], dtype=float) * sample.sponge_size_scale
        yaw_noise = max(float(base["placement_yaw_noise"]), sample.object_yaw_noise)
        self.task_config = make_config({**base, "sponge_half_size": tuple(float(h) for h in sponge),
                                        "placement_yaw_noise": yaw_noise})
        self.geometry = scene_geometry(self.task_config, self.n_segments)

    def _object_build_config(self, obj: int) -> Mapping:
        """The config object ``obj`` (0-based) is built from: the episode's, its half size scaled by the draw."""
        if self.dynamics_sample is None:
            return self.task_config
        half = np.asarray(self.base_task_config["object_half_size"], dtype=float)
        return {**self.task_config, "object_half_size": half * self.dynamics_sample.object_size_scale[obj]}

    def _built_sizes(self) -> tuple:
        """The size scales the current model was (or the next one will be) built with."""
        sample = self.dynamics_sample
        return (None, None) if sample is None else (sample.object_size_scale, sample.sponge_size_scale)

    def _arm_dofs(self) -> np.ndarray:
        return np.asarray(joint_vel_indexes(self.robots[0]), dtype=int)

    def _read_nominal(self) -> dict:
        """Copies of the model values the randomisation scales (read from a freshly built model)."""
        model = self.sim.model
        bodies = np.append(self.object_body_ids, self.sponge_body_id)
        return {
            "body_mass": model.body_mass[bodies].copy(),
            "body_inertia": model.body_inertia[bodies].copy(),
            "table_friction": model.geom_friction[self._table_mask, 0].copy(),
            "object_friction": [model.geom_friction[mask, 0].copy() for mask in self._object_masks],
            "sponge_friction": model.geom_friction[self._sponge_mask, 0].copy(),
            "dof_damping": model.dof_damping[self._arm_dofs()].copy(),
        }

    def _apply_dynamics(self, sample: DynamicsSample) -> None:
        """Write ``sample``'s masses, frictions and damping into the model and its gains into the arm's OSC.

        Scales multiply the nominal values of the built model (so soft resets do not compound).
        """
        model, nominal = self.sim.model, self._nominal
        bodies = np.append(self.object_body_ids, self.sponge_body_id)
        mass_scale = np.array([*sample.object_mass_scale, sample.sponge_mass_scale])
        model.body_mass[bodies] = nominal["body_mass"] * mass_scale
        model.body_inertia[bodies] = nominal["body_inertia"] * mass_scale[:, None]
        model.geom_friction[self._table_mask, 0] = nominal["table_friction"] * sample.table_friction_scale
        for mask, values, scale in zip(self._object_masks, nominal["object_friction"], sample.object_friction_scale):
            model.geom_friction[mask, 0] = values * scale
        model.geom_friction[self._sponge_mask, 0] = nominal["sponge_friction"] * sample.sponge_friction_scale
        model.dof_damping[self._arm_dofs()] = nominal["dof_damping"] * np.asarray(sample.joint_damping_scale)
        robot = self.robots[0]
        osc = robot.composite_controller.part_controllers.get(robot.arms[0])
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

    def _grasped(self, object_mask: np.ndarray) -> bool:
        """Both finger pads touch a geom of ``object_mask`` (robosuite's grasp criterion, vectorised)."""
        data = self._mj_data
        ncon = data.ncon
        if ncon == 0:
            return False
        geom1, geom2 = data.contact.geom1[:ncon], data.contact.geom2[:ncon]
        return all(wiping.any_contact(geom1, geom2, pad, object_mask).any() for pad in self._finger_pad_masks)

    def sponge_press_force(self) -> float:
        """Normal force [N] (>= 0) the sponge presses on the table top: the sum over their MuJoCo
        contacts (``mj_contactForce``) in the current simulation data."""
        data = self._mj_data
        native = self._press_native
        if native is None or native[0] is not data:
            native = self._press_native = self._bind_press_native(data)
        # data.contact's arrays hold the ncon active contacts (none: empty; the sums are 0.0)
        if native[2] is not None:  # the same sum in one compiled call (read every control step a wipe presses)
            return press_normal_force(native[2], data.contact.geom, native[3], native[4])
        contact = data.contact
        pressing = contacts_between(contact.geom1, contact.geom2, self._sponge_mask, self._table_mask).tolist()
        if not pressing:
            return 0.0
        model = native[1]
        wrench = np.zeros(CONTACT_WRENCH_SIZE)
        total = 0.0
        for i in pressing:
            mujoco.mj_contactForce(model, data, i, wrench)
            total += float(wrench[0])
        return max(total, 0.0)

    #: (data, model, native addresses or None, geom roles, (6,) scratch) of :meth:`sponge_press_force`'s compiled
    #: sum, per simulation data (:meth:`_bind_press_native`; dropped when the masks are rebuilt)
    _press_native: tuple | None = None

    def _bind_press_native(self, data) -> tuple:
        """:attr:`_press_native` for the simulation data ``data`` (the model and data are kept alive with their
        addresses): :func:`~.contact_kernels.press_normal_force`'s (3,) int64 addresses (None without the
        native ``mj_contactForce``) and (ngeom,) int64 roles (the sponge's geoms :data:`PRESSING`, the table
        top's :data:`SURFACE`)."""
        model = mj_model(self.sim)
        function = mujoco_contact_force_address()
        if function is None:
            return (data, model, None, None, None)
        native = np.zeros(3, dtype=np.int64)
        native[[NATIVE_CONTACT_FORCE, NATIVE_MODEL, NATIVE_DATA]] = [function, c_address(model), c_address(data)]
        roles = np.zeros(self._sponge_mask.size, dtype=np.int64)
        roles[self._sponge_mask] |= PRESSING
        roles[self._table_mask] |= SURFACE
        return (data, model, native, roles, np.zeros(CONTACT_WRENCH_SIZE))

    def record_wiping_substep(self) -> None:
        """Removes markers under the sponge when it presses on the table top (current substep state).

        The per-physics-substep hook: ``env.step`` calls it after each substep's control, and so
        does a fast stepper (:mod:`tableclean_suite.controllers.fast_control`) that runs the
        substeps itself.  Cheap when the sponge is clearly above the table.
        """
        data = self._mj_data
        config = self.task_config
        sponge_pos, sponge_mat = data.xpos[self.sponge_body_id], data.xmat[self.sponge_body_id]
        # cheap early exit (most substeps): the sponge's lowest corner is clearly above the table
        lowest = wiping.box_lowest_z(sponge_pos, sponge_mat, config["sponge_half_size"])
        if lowest > self.geometry.table_top_z + max(config["wipe_contact_dist"], 0.0) + PRESS_PREFILTER_SLACK:
            return
        ncon = data.ncon
        contact = data.contact
        if not contact_within(contact.geom1[:ncon], contact.geom2[:ncon], contact.dist[:ncon], self._sponge_mask,
                              self._table_mask, float(config["wipe_contact_dist"])):
            return
        under = wiping.markers_under_box(
            self._marker_xyz, sponge_pos, sponge_mat, config["sponge_half_size"], config["wipe_marker_reach"]
        )
        present = self._marker_present()
        if (under & present).any():
            self._write_marker_present(present & ~under)

    def show_dirt(self) -> None:
        """Marker visuals follow the dirt state: alpha 0 for wiped markers, 1 for present ones.

        The per-control-step hook (``env.step`` and a fast stepper call it once per control step).
        Cheap when nothing changed since the last call (compares the dirt-state joint positions).
        """
        positions = self._dirt_positions()
        if positions == self._shown_dirt:
            return
        self.sim.model.geom_rgba[self.marker_geom_ids, 3] = self._marker_present().astype(float)
        self._shown_dirt = positions

    # the v1 private names of the two hooks
    _record_wiping = record_wiping_substep
    _show_dirt = show_dirt

    def _symbolic_index(self) -> int:
        """Index of :meth:`symbolic_state` without the sponge check, or ``FAULT_INDEX`` on a fault."""
        try:
            return self.symbolic_state(check_sponge=False).index
        except abstraction.AbstractionError:
            return FAULT_INDEX


#: :meth:`TableClean.skill_info`'s keys computed on first read (:class:`~.skill_info.SkillInfo`), by group.
LAZY_SKILL_INFO = {
    key: fill
    for keys, fill in (
        (("object_pos",), TableClean._info_object_pos),
        (("eef_quat",), TableClean._info_eef_quat),
        (("eef_rot",), TableClean._info_eef_rot),
        (("objects_quat",), TableClean._info_objects_quat),
        (("object_quat",), TableClean._info_object_quat),
        (("objects_grasped", "object_grasped", "sponge_grasped"), TableClean._info_grasped),
        (("sponge_pos", "sponge_quat"), TableClean._info_sponge),
        (("dirt_fraction",), TableClean._info_dirt),
        (("qvel",), TableClean._info_qvel),
    )
    for key in keys
}
