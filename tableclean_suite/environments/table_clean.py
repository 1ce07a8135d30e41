"""The ``TableClean`` robosuite environment: robosuite's hooks and the public methods (the jobs behind them live in
[arguments][tableclean_suite.environments.arguments], [scene_building][tableclean_suite.environments.scene_building],
[randomization][tableclean_suite.environments.randomization], [state_reading][tableclean_suite.environments.state_reading]
and [skill_info][tableclean_suite.environments.skill_info])."""

from __future__ import annotations

from typing import Iterable, Mapping

import numpy as np
from robosuite.environments.manipulation.manipulation_env import ManipulationEnv
from robosuite.models.tasks import ManipulationTask
from robosuite.utils.observables import Observable, sensor
from robosuite.utils.transform_utils import convert_quat

from tableclean_suite.environments import abstraction, placement, wiping
from tableclean_suite.environments.arena import TableCleanArena
from tableclean_suite.environments.arguments import (FROM_SPEC, check_controller_configs, check_episode_settings,
                                                     check_finite_action, start_layout)
from tableclean_suite.environments.config import (DEFAULT_TABLECLEAN_CONFIG, jsonable, make_config, marker_positions,
                                                  scene_geometry)
from tableclean_suite.environments.gripper_geometry import measure_gripper
from tableclean_suite.environments.object_geometry import object_geometry
from tableclean_suite.environments.objects import (check_holdable, get_object_type, make_object, make_sponge,
                                                   object_names, type_geometry)
from tableclean_suite.environments.randomization import (DynamicsRandomization, DynamicsSample, DynamicsTargets,
                                                         apply_dynamics, episode_config, object_build_config,
                                                         read_nominal, resolve_randomization)
from tableclean_suite.environments.robot_registry import base_shift, check_robot, scene_gripper_types
from tableclean_suite.environments.scene_building import (ObjectMeasures, ResetLayouts, check_objects_fit,
                                                          check_randomization_fits, exclude_parent_contacts,
                                                          hover_qpos, resting_qpos, sponge_start_qpos)
from tableclean_suite.environments.scene_state import SceneState, read_scene_state, write_scene_state
from tableclean_suite.environments.skill_info import (DataViews, SceneNotResetError, SkillInfo, SkillInfoReader,
                                                     constant_values)
from tableclean_suite.environments.state_reading import Contacts, DirtMarkers
from tableclean_suite.robosuite_adapter import gripper_joint_pos_indexes, joint_vel_indexes, mj_data, mj_model
from tableclean_suite.task import HELD, StartMode, TaskModel, TaskSpec, TaskState, get_task_spec

__all__ = ["TableClean", "DEFAULT_TABLECLEAN_CONFIG", "FROM_SPEC"]

#: robosuite's name of the table's collision geom: the surface the sponge must press on.
TABLE_TOP_GEOM = "table_collision"
#: Value of the ``symbolic_state_index`` observable when the abstraction reports a fault.
FAULT_INDEX = -1
#: At reset the grip site hovers at least this far above the tallest object's top [m] (the open
#: fingertips hang ~1.4 cm below it on the Panda gripper), so a tall object is not knocked over.
RESET_OBJECT_CLEARANCE = 0.05
#: The exact contact test runs only when the sponge's lowest corner is within this of the table top [m].
PRESS_PREFILTER_SLACK = 0.002

# Un-normalised reward components (see TableClean.reward).
SUCCESS_REWARD = 3.0
WIPE_REWARD_PER_SEGMENT = 1.0
OBJECT_ON_TABLE_REWARD = 0.25
SPONGE_RETURNED_REWARD = 0.5
#: The wiping component spans [0, this] (the paper's two segments) whatever the number of segments.
PAPER_REWARD_SEGMENTS = 2


class TableClean(ManipulationEnv):
    """Clean every segment of a table with a sponge, moving objects out of the way (one robot arm).

    ## Description
    The scene builds a task spec (``task``, default ``paper``): N segments and M objects of the
    spec's types ([`objects`][tableclean_suite.environments.objects] registry).  For N = 2 the table top is split along y
    into segment 1 (at -y, blue) and segment 2 (at +y, orange); N = 3, 4 lay out two rows of two
    smaller segments ([`config.segment_layout`][tableclean_suite.environments.config.segment_layout]; larger N raise a ``ValueError``).
    Each segment is covered with a grid of dirt markers; a sponge rests on a stand off every segment.
    A marker is wiped (checked at every physics substep) when the sponge's underside presses on the
    table top over it.  The wiped flags are MuJoCo state (one dirt-state joint per segment,
    [`dirt_state`][tableclean_suite.environments.dirt_state]), so ``sim.get_state()`` / ``sim.set_state_from_flattened()``
    save and restore the cleaning; wiped markers are hidden (alpha 0).

    ## Starting State
    The gripper hovers ``arm_hover_height`` above the centre of ``arm_segment`` (a cached IK pose plus
    ``initialization_noise``), open; the objects lie on their segments with ``placement_noise``; the
    sponge is at home; the segments in ``dirty_segments`` are fully dirty, the others clean.  With the
    defaults and ``object_segment=arm_segment=1`` [`symbolic_state`][tableclean_suite.environments.table_clean.TableClean.symbolic_state] is Table 1's state 4.

    ## Rewards
    See [`reward`][tableclean_suite.environments.table_clean.TableClean.reward].  The episode ends after ``horizon`` steps unless ``ignore_done``.

    ## Arguments
    Besides those of robosuite's ``ManipulationEnv`` (passed through):

    - ``robots``: one robot with a registered skill config
      ([`supported_robots`][tableclean_suite.environments.robot_registry.supported_robots], e.g. ``"Panda"``); others raise
      a ``ValueError``.  ``gripper_types="default"`` mounts the gripper the robot's config names.
    - ``task`` (name, [`TaskSpec`][tableclean_suite.task.spec.TaskSpec] or ``.json`` path; default ``"paper"``): the spec the scene builds.
    - Layout (``object_segment``, ``object_segments``, ``arm_segment``, ``dirty_segments``): when none
      is given and ``task`` is, the resets start in the spec's ``start_state`` (a state holding an
      object is refused: stage it with [`stage`][tableclean_suite.physics_backend.stage]) or, for
      ``start="uniform_unclean"``, in a fresh all-dirty draw.  A layout argument given wins (the others
      keep the defaults below); without ``task`` every layout is drawn.
    - ``object_segment`` (1..N or None): the segment every object starts on; None draws each at each reset.
    - ``object_segments`` (M entries, 1..N or None): per-object start segments; overrides ``object_segment``.
    - ``arm_segment`` (1..N or None): the segment the arm starts above; None draws it at each reset.
    - ``dirty_segments`` (collection of 1..N; None: all): the segments that start dirty.
    - ``task_config`` (dict): overrides of `DEFAULT_TABLECLEAN_CONFIG` (unknown keys raise).
    - ``use_object_obs`` (bool): include the object, sponge, dirt and symbolic observables.
    - ``reward_scale`` (float or None): the maximum reward; None leaves rewards un-normalised.
    - ``reward_shaping`` (bool): use the staged dense reward.
    - ``randomization`` (None/"off", "on", a [`DynamicsRandomization`][tableclean_suite.environments.randomization.DynamicsRandomization]
      or a mapping of its fields over the "on" ranges unless it says ``"base": "off"``): dynamics drawn
      at every reset from ``self.rng`` (ranges and units in [`randomization`][tableclean_suite.environments.randomization]).
      The draw is ``self.dynamics_sample``; ``self.task_config`` then holds the episode's sponge size
      (``self.base_task_config`` the configured one).
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
        self.robot_name: str = check_robot(robots)
        check_episode_settings(horizon, control_freq)
        check_controller_configs(controller_configs)
        gripper_types = scene_gripper_types(self.robot_name, gripper_types)  # the robot config may swap it
        #: the configured task config; ``task_config`` is this episode's (randomised sizes, see randomization=)
        self.base_task_config = make_config(task_config)
        self.task_config = self.base_task_config
        #: the ranges drawn at every reset (`OFF`: none)
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
        check_randomization_fits(self.randomization, self.object_types, self.geometry, self.base_task_config)
        #: (M,) m footprints built from the unrandomised config (a drawn size grows an overridden one alike)
        self._nominal_footprints = np.array(
            [type_geometry(kind, self.task_config).footprint_radius for kind in self.object_types], dtype=float)
        layout = (object_segment, arm_segment, dirty_segments, object_segments)
        if task is not None and all(value is FROM_SPEC for value in layout):
            if self.task_model.start == StartMode.FIXED:
                self.set_start_state(self.task_model.start_state)
            else:  # uniform_unclean: all dirty, each position drawn uniformly
                self.set_start(None, None, None)
        else:
            object_segment, arm_segment, dirty_segments, object_segments = (
                None if value is FROM_SPEC else value for value in layout)
            self.set_start(object_segment, arm_segment, dirty_segments, object_segments=object_segments)
        self.reward_scale = reward_scale
        self.reward_shaping = reward_shaping
        self.use_object_obs = use_object_obs
        marker_xy = marker_positions(self.task_config, self.n_segments).reshape(-1, 2)
        self._markers_per_segment = len(marker_xy) // self.n_segments
        #: (N * K, 3) the dirt markers' centres on the table top [m], segment 1's first
        self._marker_xyz = np.column_stack([marker_xy, np.full(len(marker_xy), self.geometry.table_top_z)])
        self._arm_qpos_cache: dict[tuple, np.ndarray] = {}
        # (object segment, arm segment) of this episode, 0-based; with M > 1 objects (object segments, arm segment)
        self.layout: tuple | None = None
        super().__init__(
            robots=robots, env_configuration=env_configuration, controller_configs=controller_configs,
            base_types=base_types, gripper_types=gripper_types, initialization_noise=initialization_noise,
            use_camera_obs=use_camera_obs, has_renderer=has_renderer, has_offscreen_renderer=has_offscreen_renderer,
            render_camera=render_camera, render_collision_mesh=render_collision_mesh,
            render_visual_mesh=render_visual_mesh, render_gpu_device_id=render_gpu_device_id,
            control_freq=control_freq, lite_physics=lite_physics, horizon=horizon, ignore_done=ignore_done,
            hard_reset=hard_reset, camera_names=camera_names, camera_heights=camera_heights,
            camera_widths=camera_widths, camera_depths=camera_depths, camera_segmentations=camera_segmentations,
            renderer=renderer, renderer_config=renderer_config, seed=seed)
        try:  # ValueError (the scene closed) naming an object the open gripper cannot take
            for kind, shape in zip(self.object_types, self.object_geometries):
                check_holdable(kind, shape, self.gripper_geometry.open_width, f"{self.robot_name} gripper")
        except ValueError:
            self.close()
            raise

    # -- robosuite hooks ------------------------------------------------------------------------
    def reward(self, action=None) -> float:
        """The reward (pure; ``action`` unused): 3.0 on success (every segment clean, objects on the table, sponge
        home), else with ``reward_shaping`` the sum of [`staged_rewards`][tableclean_suite.environments.table_clean.TableClean.staged_rewards] (at most 2.75),
        else 0; times ``reward_scale / 3`` unless ``reward_scale`` is None."""
        reward = 0.0
        if self._check_success():
            reward = SUCCESS_REWARD
        elif self.reward_shaping:
            reward = sum(self.staged_rewards())
        if self.reward_scale is not None:
            reward *= self.reward_scale / SUCCESS_REWARD
        return reward

    def staged_rewards(self) -> tuple[float, float, float]:
        """Un-normalised shaping components: wiping in [0, 2] (per segment min(1, wiped fraction /
        clean_fraction), averaged, times 2), object on the table 0.25 when every object lies on a segment (none
        held), sponge returned 0.5 when a segment is clean and the sponge is home."""
        info = self.skill_info()
        wiped = 1.0 - info["dirt_fraction"]
        # scaled to the paper's two segments' range [0, 2] whatever N is, so the total stays below success
        per_segment = np.minimum(1.0, wiped / self.task_config["clean_fraction"])
        r_wipe = WIPE_REWARD_PER_SEGMENT * float(per_segment.mean()) * PAPER_REWARD_SEGMENTS
        r_object = OBJECT_ON_TABLE_REWARD if self._objects_on_table(info) else 0.0
        clean = abstraction.segments_clean(info["dirt_fraction"], self.task_config)
        returned = bool(clean.any()) and abstraction.sponge_at_home(info, self.task_config)
        r_sponge = SPONGE_RETURNED_REWARD if returned else 0.0
        return r_wipe, r_object, r_sponge

    def _load_model(self):
        """Loads the arena (table, segments, dirt, stand), the robot, the objects and the sponge into self.model."""
        super()._load_model()
        if self.randomization.enabled and self.dynamics_sample is None:  # the constructor's scene
            self._draw_dynamics()
        config = self.task_config
        robot_model = self.robots[0].robot_model
        robot_model.set_base_xpos(np.add(robot_model.base_xpos_offset["table"](config["table_full_size"][0]),
                                          base_shift(self.robot_name)))  # some arms sit closer (robot configs)
        exclude_parent_contacts(robot_model)  # a fixed base's first link must not collide with it (Sawyer)
        self.arena = arena = TableCleanArena(
            self.geometry, self._marker_xyz[:, :2].reshape(self.n_segments, self._markers_per_segment, 2),
            config["marker_radius"], config["table_full_size"], config["table_friction"], config["table_offset"])
        arena.set_origin([0, 0, 0])
        #: the M task objects (robosuite MujocoObjects), object 1 first; ``self.object`` is object 1
        self.objects = [
            make_object(kind.name, object_build_config(self.base_task_config, config, self.dynamics_sample, j), name)
            for j, (kind, name) in enumerate(zip(self.object_types, object_names(self.n_objects)))]
        self.object = self.objects[0]
        #: the objects' collision geometry in their own frames ([`object_geometry`][tableclean_suite.environments.object_geometry.object_geometry])
        self.object_geometries = tuple(object_geometry(o) for o in self.objects)
        self.sponge = make_sponge(config["sponge_half_size"], config["sponge_density"])
        self.model = ManipulationTask(mujoco_arena=arena, mujoco_robots=[robot.robot_model for robot in self.robots],
                                      mujoco_objects=[*self.objects, self.sponge])

    def _setup_references(self):
        """Ids of the objects, sponge, table top and dirt markers, and the readers of this simulation's state."""
        super()._setup_references()
        model, raw_model = self.sim.model, mj_model(self.sim)
        self._mj_data = data = mj_data(self.sim)
        self.object_body_ids = np.array([model.body_name2id(o.root_body) for o in self.objects])
        self.object_body_id = int(self.object_body_ids[0])
        self.sponge_body_id = model.body_name2id(self.sponge.root_body)
        robot = self.robots[0]
        arm = robot.arms[0]
        gripper = robot.gripper[arm]

        def mask(names):
            return wiping.geom_mask(model.ngeom, [model.geom_name2id(n) for n in names])

        table, sponge = mask([TABLE_TOP_GEOM]), mask(self.sponge.contact_geoms)
        objects = tuple(mask(o.contact_geoms) for o in self.objects)
        #: the objects' sizes as built ([ObjectMeasures][tableclean_suite.environments.scene_building.ObjectMeasures])
        self.object_measures = ObjectMeasures.of(self.object_types, self.object_geometries, self.geometry.table_top_z,
                                                 self._nominal_footprints)
        self._reset_layouts = ResetLayouts(self.object_measures.outlines)
        self.gripper_geometry = measure_gripper(raw_model, data.qpos.copy(), gripper,
                                                gripper.important_sites["grip_site"])
        pads = (mask(gripper.important_geoms["left_fingerpad"]), mask(gripper.important_geoms["right_fingerpad"]))
        #: [Contacts][tableclean_suite.environments.state_reading.Contacts]: the grasp test, the sponge's press
        self.contacts = Contacts(raw_model, data, table, sponge, objects, pads)
        self.marker_geom_ids = np.array([model.geom_name2id(n) for n in self.arena.marker_names])
        joints = tuple(self.arena.dirt_state_joint_names)  # one per segment
        #: the dirt markers' flags and visuals ([DirtMarkers][tableclean_suite.environments.state_reading.DirtMarkers])
        self.dirt = DirtMarkers(data, joints, [model.get_joint_qpos_addr(j) for j in joints],
                                [model.get_joint_qvel_addr(j) for j in joints], self._markers_per_segment,
                                raw_model.geom_rgba, self.marker_geom_ids)
        fingers = gripper_joint_pos_indexes(robot, arm)
        views = DataViews.of(data, robot.eef_site_id[arm], fingers, self.object_body_ids, self.sponge_body_id)
        # a skill_info's stamp: the scene's state writes that need not move the clock, and the simulation time [s]
        self._info_reader = SkillInfoReader(views, self.contacts.grasped, self.dirt.fraction,
                                            lambda: (self._state_epoch, self._mj_data.time))
        self._constant_info: tuple | None = None  # (config, geometry, skill_info's constant values)
        self._dynamics_targets = DynamicsTargets(np.append(self.object_body_ids, self.sponge_body_id), table, objects,
                                                 sponge, np.asarray(joint_vel_indexes(robot), dtype=int))
        if self.sim is not self._nominal_sim:  # a new model: remember its unrandomised values
            self._nominal_sim = self.sim
            self._nominal = read_nominal(model, self._dynamics_targets)

    def _setup_observables(self):
        """The robot's proprioception plus, with ``use_object_obs``, the object, sponge, dirt and symbolic-state
        observables (an OrderedDict name -> ``Observable``)."""
        observables = super()._setup_observables()
        if not self.use_object_obs:
            return observables
        modality = "object"

        def named(name, read):
            def read_sensor(obs_cache):
                return read()
            read_sensor.__name__ = name
            return sensor(modality=modality)(read_sensor)

        def xpos(ids):
            return lambda: np.array(self.sim.data.body_xpos[ids])

        def xquat(body):
            return lambda: convert_quat(np.array(self.sim.data.body_xquat[body]), to="xyzw")

        sensors = [named("object_pos", xpos(self.object_body_id)), named("object_quat", xquat(self.object_body_id)),
                   named("sponge_pos", xpos(self.sponge_body_id)), named("sponge_quat", xquat(self.sponge_body_id)),
                   named("dirt_fraction", self.dirt_fraction)]
        if self.n_objects > 1:
            sensors += [named("objects_pos", lambda: xpos(self.object_body_ids)().ravel()),
                        named("objects_quat", lambda: np.concatenate([xquat(j)() for j in self.object_body_ids]))]

        @sensor(modality=modality)
        def symbolic_state_onehot(obs_cache):
            cached = obs_cache.get("symbolic_state_index")
            index = self._symbolic_index() if cached is None else int(cached)
            onehot = np.zeros(self.task_model.n_states)
            if index != FAULT_INDEX:
                onehot[index] = 1.0
            return onehot

        arm_prefixes = self._get_arm_prefixes(self.robots[0], include_robot_name=False)
        full_prefixes = self._get_arm_prefixes(self.robots[0])
        sensors += [
            self._get_obj_eef_sensor(full_pf, "object_pos", f"{arm_pf}gripper_to_object_pos", modality)
            for arm_pf, full_pf in zip(arm_prefixes, full_prefixes)
        ]
        sensors += [named("symbolic_state_index", self._symbolic_index), symbolic_state_onehot]
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
            robot = self.robots[0]
            apply_dynamics(self.sim.model, self._dynamics_targets, self._nominal, self.dynamics_sample,
                           robot.composite_controller.part_controllers.get(robot.arms[0]))
        if not self.deterministic_reset:  # objects on their segments (ValueError when they do not fit), sponge home
            for j, xy, yaw in self._reset_layouts.draw(self.rng, objects, self.geometry, self.task_config):
                self._set_object_pose(j, xy, yaw)
            self.sim.data.set_joint_qpos(self.sponge.joints[0],
                                         sponge_start_qpos(self.geometry, self.task_config, self.dynamics_sample))
        dirty = np.zeros((self.n_segments, self._markers_per_segment), dtype=bool)
        dirty[list(self.dirty_segments)] = True
        self.dirt.write(dirty.ravel())
        self.show_dirt()

    def reset(self):
        """robosuite's reset, after drawing this episode's randomised dynamics (when ``randomization`` is on); a
        draw that changes a size rebuilds the MuJoCo model first, also with ``hard_reset=False``."""
        if not (self.randomization.enabled and not self.deterministic_reset):
            return super().reset()
        built = self._built_sizes()
        self._draw_dynamics()
        hard_reset = self.hard_reset  # robosuite's hard reset rebuilds the model and re-binds the sensors
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

    def _check_success(self) -> bool:
        """Every segment clean, every object lying on a segment, the sponge at home."""
        if not abstraction.segments_clean(self.dirt_fraction(), self.task_config).all():
            return False
        info = self.skill_info()
        return self._objects_on_table(info) and abstraction.sponge_at_home(info, self.task_config)

    def _objects_on_table(self, info: Mapping) -> bool:
        """Every object lies on a segment (none held); False when the abstraction reports a fault."""
        try:
            return HELD not in abstraction.object_locations(info, self.task_config)
        except abstraction.AbstractionError:
            return False

    # -- public API for skills and learners ----------------------------------------------------
    def set_start(self, object_segment: int | None, arm_segment: int | None,
                  dirty_segments: Iterable[int] | None = None, *,
                  object_segments: Iterable[int | None] | None = None) -> None:
        """The layout of the following resets, as the constructor's arguments (1-based segment numbers 1..N, None:
        drawn at each reset; ``dirty_segments`` None: all).  Stored 0-based in the attributes of the same names;
        ``ValueError`` naming a bad value (nothing changes then)."""
        layout = start_layout(self.n_segments, self.n_objects, object_segment, arm_segment, dirty_segments,
                              object_segments)
        self.object_segment, self.object_segments, self.arm_segment, self.dirty_segments = layout

    def set_start_state(self, state: TaskState) -> None:
        """The following resets start in the task state ``state``; ``ValueError`` for a state of another size or one
        holding an object (stage that with [`stage`][tableclean_suite.physics_backend.stage])."""
        state = self.task_model.as_state(state)
        if state.holding:
            raise ValueError(f"task {self.task_spec.name!r}: {state.name} holds an object; TableClean resets with every "
                             "object lying: pass a layout (object_segment=..., arm_segment=...) and stage the held "
                             "state after a reset with tableclean_suite.physics_backend.stage")
        self.set_start(None, state.arm + 1, [k + 1 for k in range(state.n_segments) if not state.is_clean(k)],
                       object_segments=[where + 1 for where in state.objects])

    def put_object(self, obj: int, segment: int) -> None:
        """Teleport object ``obj`` (0-based), at rest, onto the free spot of ``segment`` (0-based) the place skill
        would choose ([`free_spot`][tableclean_suite.environments.placement.free_spot]); the physics is forwarded, not stepped."""
        info = self.skill_info()
        tolerance = self.task_config["lift_tolerance"]  # the others lying (near their rest height) on the segment
        others = [(pos, placement.footprint_of(info, k)) for k, pos in enumerate(info["objects_pos"]) if k != obj
                  and pos[2] <= info["objects_rest_z"][k] + tolerance and self.segment_of_position(pos) == segment]
        xy = placement.free_spot(self.geometry.segment_centers[segment], self.geometry.segment_half_sizes[segment],
                                 self.object_measures.outlines[obj], others, self.task_config["object_clearance"],
                                 placement.other_segments(self.geometry.segment_centers,
                                                          self.geometry.segment_half_sizes, segment))
        self._set_object_pose(obj, xy, 0.0)
        self.sim.forward()

    def dirt_fraction(self) -> np.ndarray:
        """(N,) fraction of each segment's dirt markers still present (1.0 = all dirty), read from qpos;
        [`DirtStateError`][tableclean_suite.environments.dirt_state.DirtStateError] when a dirt-state joint holds no valid code."""
        return self.dirt.fraction()

    def skill_info(self) -> SkillInfo:
        """Grounding for skills and the abstraction (world frame, metres, quaternions xyzw).

        Keys: ``eef_pos`` (3,), ``eef_quat`` (4,), ``eef_rot`` (3, 3) the grip site's rotation matrix (the
        matrix ``eef_quat`` is converted from), ``gripper_qpos`` (2,), ``object_pos`` (3,),
        ``object_quat`` (4,), ``object_half_size`` (3,) bounding half extents, ``object_rest_z``
        object centre height when resting on the table (these four: object 1), ``objects_pos``
        (M, 3), ``objects_quat`` (M, 4), ``objects_half_size`` (M, 3), ``objects_rest_z`` (M,),
        ``objects_grasped`` (M,) bool, ``object_types`` (M,) the objects'
        [`ObjectType`][tableclean_suite.environments.objects.ObjectType] (overrides), ``objects_geometry``
        (M,) their [`ObjectGeometry`][tableclean_suite.environments.object_geometry.ObjectGeometry] (collision extent in their own frames),
        ``objects_footprint`` (M,) m footprint radii, ``gripper_open_width`` m (open pad gap) and
        ``gripper_palm_height`` m (hand's lowest point above the grip site) and ``gripper_hand_reach`` m
        (how far the hand reaches sideways from the grip site, [`gripper_geometry`][tableclean_suite.environments.gripper_geometry]),
        ``gripper_hand_half_width`` m (how far it reaches across the fingers' closing axis),
        ``sponge_pos`` (3,), ``sponge_quat`` (4,), ``sponge_half_size`` (3,), ``sponge_home_pos`` (3,),
        ``segment_centers`` (N, 3) table-top point at each segment centre (row 0 = segment 1),
        ``segment_half_sizes`` (N, 2), ``table_top_z`` float, ``table_center`` (3,),
        ``table_half_size`` (2,), ``robot_base_pos`` (3,) the arm's base (its root body), ``object_grasped``
        (object 1) and ``sponge_grasped`` bool (both finger pads touch it), ``dirt_fraction`` (N,),
        ``qvel`` (nv,) all simulation velocities, ``object_spacing`` and ``object_clearance`` (the config's).

        A [SkillInfo][tableclean_suite.environments.skill_info.SkillInfo] (a dict): the constant values are shared
        read-only arrays, the costlier per-step ones are computed on first read.  ``SceneNotResetError`` before
        the first ``reset()``.
        """
        data = self._mj_data
        if not data.xpos[self.object_body_ids].any():  # every object at the world origin: never forwarded
            raise SceneNotResetError("TableClean.skill_info() before reset(): the scene's positions are not computed "
                                     "yet; call env.reset() first")
        constant = self._constant_info
        if constant is None or constant[0] is not self.task_config or constant[1] is not self.geometry:
            constant = self._constant_info = (self.task_config, self.geometry, constant_values(
                self.object_measures, self.gripper_geometry, self.task_config, self.geometry,
                self.sponge.get_bounding_box_half_size(),
                data.xpos[mj_model(self.sim).body(self.robots[0].robot_model.root_body).id]))
        return self._info_reader.read(constant[2], (self._state_epoch, data.time))

    #: Writes of the scene's state that need not move the clock (resets, set_scene_state, put_object).
    _state_epoch = 0

    def symbolic_state(self, check_sponge: bool = True) -> TaskState:
        """The current [`TaskState`][tableclean_suite.task.state.TaskState] read from the physics (``check_sponge``: require the sponge
        at home); ``AbstractionError`` when it maps to no task state (``.fault`` names why)."""
        return abstraction.abstract_state(self.skill_info(), self.task_config, check_sponge=check_sponge)

    def segment_of_position(self, xy) -> int | None:
        """The segment whose cleanable area contains world ``xy`` (first two entries used), else None."""
        return abstraction.segment_of_xy(xy, self.geometry.segment_centers, self.geometry.segment_half_sizes)

    def get_scene_state(self) -> SceneState:
        """A copy of everything needed to put the scene back later ([`SceneState`][tableclean_suite.environments.scene_state.SceneState])."""
        return read_scene_state(mj_data(self.sim), self.robots)

    def set_scene_state(self, state: SceneState) -> None:
        """Put the scene back into ``state`` (from [`get_scene_state`][tableclean_suite.environments.table_clean.TableClean.get_scene_state] of this env)."""
        write_scene_state(mj_data(self.sim), self.robots, state)  # ValueError for another model's state
        self._state_epoch += 1
        self.show_dirt()
        self.sim.forward()

    def get_ep_meta(self) -> dict:
        """robosuite's episode metadata (JSON-serialisable) plus ``task_spec`` (``TaskSpec.to_dict()``),
        ``object_types`` (names), ``task_config`` and ``start`` (``object_segment``, ``arm_segment``,
        ``dirty_segments`` and with M > 1 ``object_segments``, 1-based; None: drawn at each reset); with
        randomisation on, ``randomization`` and ``dynamics_sample``."""
        meta = super().get_ep_meta()

        def number(segment):
            return None if segment is None else segment + 1

        meta.update(task_spec=self.task_spec.to_dict(), object_types=[kind.name for kind in self.object_types],
                    task_config=jsonable(self.task_config),
                    start={"object_segment": number(self.object_segment), "arm_segment": number(self.arm_segment),
                           "dirty_segments": [k + 1 for k in self.dirty_segments]})
        if self.n_objects > 1:  # one entry per object
            meta["start"]["object_segments"] = [number(k) for k in self.object_segments]
        if self.randomization.enabled:
            meta["randomization"] = self.randomization.to_dict()
            meta["dynamics_sample"] = None if self.dynamics_sample is None else self.dynamics_sample.to_dict()
        return meta

    # -- per-step hooks: wiping and the markers' visuals ----------------------------------------
    def record_wiping_substep(self) -> None:
        """Removes the markers under the sponge when it presses on the table top: the per-physics-substep hook
        (``env.step`` and a fast stepper call it after each substep's control)."""
        data = self._mj_data
        config = self.task_config
        sponge_pos, sponge_mat = data.xpos[self.sponge_body_id], data.xmat[self.sponge_body_id]
        # cheap early exit (most substeps): the sponge's lowest corner is clearly above the table
        lowest = wiping.box_lowest_z(sponge_pos, sponge_mat, config["sponge_half_size"])
        if lowest > self.geometry.table_top_z + max(config["wipe_contact_dist"], 0.0) + PRESS_PREFILTER_SLACK:
            return
        if not self.contacts.sponge_on_table(config["wipe_contact_dist"]):
            return
        under = wiping.markers_under_box(self._marker_xyz, sponge_pos, sponge_mat, config["sponge_half_size"],
                                         config["wipe_marker_reach"])
        present = self.dirt.present()
        if (under & present).any():
            self.dirt.write(present & ~under)

    def show_dirt(self) -> None:
        """Marker visuals follow the dirt state (alpha 0: wiped): the per-control-step hook."""
        self.dirt.show()

    def sponge_press_force(self) -> float:
        """Normal force [N] (>= 0) the sponge presses on the table top (``mj_contactForce`` summed)."""
        return self.contacts.press_force()

    def _symbolic_index(self) -> int:
        """Index of the symbolic state without the sponge check, or ``FAULT_INDEX`` on a fault."""
        try:
            return self.symbolic_state(check_sponge=False).index
        except (abstraction.AbstractionError, SceneNotResetError):  # a fault, or before the first reset
            return FAULT_INDEX

    # -- the reset's layout and randomised dynamics --------------------------------------------
    def _draw_layout(self) -> tuple[tuple[int, ...], int]:
        """(object segments (M,), arm segment): the configured ones, or drawn from ``self.rng`` when None."""
        # always drawn (objects, then the arm), so the rng stream does not depend on the configured layout
        draws = self.rng.integers(0, self.n_segments, size=self.n_objects + 1)
        objects = tuple(int(d) if k is None else k for k, d in zip(self.object_segments, draws[:-1]))
        arm = self.arm_segment if self.arm_segment is not None else int(draws[-1])
        return objects, arm

    def _arm_reset_qpos(self, segment: int) -> np.ndarray:
        """Joint positions putting the gripper site ``arm_hover_height`` above ``segment``'s centre, or
        `RESET_OBJECT_CLEARANCE` above the tallest object's top when that is higher (cached)."""
        tallest = max(float(g.height) for g in self.object_geometries)
        height = max(float(self.task_config["arm_hover_height"]), tallest + RESET_OBJECT_CLEARANCE)
        key = (segment, height)
        if key not in self._arm_qpos_cache:
            target = self.geometry.segment_centers[segment] + [0.0, 0.0, height]
            self._arm_qpos_cache[key] = hover_qpos(self.sim, self.robots[0], target)
        return self._arm_qpos_cache[key].copy()

    def _set_object_pose(self, obj: int, xy, yaw: float) -> None:
        """Object ``obj`` at rest on the table at world ``xy`` with ``yaw`` [rad] (qpos set, qvel zeroed)."""
        self._state_epoch += 1
        rest_z = self.geometry.table_top_z - float(self.object_geometries[obj].lower[2])
        joint = self.objects[obj].joints[0]
        self.sim.data.set_joint_qpos(joint, resting_qpos(xy, yaw, rest_z))
        self.sim.data.set_joint_qvel(joint, np.zeros(6))

    def _draw_dynamics(self) -> None:
        """Draw this episode's ``DynamicsSample`` from ``self.rng``; the episode's config and geometry follow."""
        n_joints = len(self.robots[0].robot_model.joints)
        self.dynamics_sample = self.randomization.sample(self.rng, self.n_objects, n_joints)
        self.task_config = episode_config(self.base_task_config, self.dynamics_sample)
        self.geometry = scene_geometry(self.task_config, self.n_segments)

    def _built_sizes(self) -> tuple:
        """The size scales the current model was (or the next one will be) built with."""
        sample = self.dynamics_sample
        return (None, None) if sample is None else (sample.object_size_scale, sample.sponge_size_scale)
