"""The typed state a skill hands to the compiled [control_loop][tableclean_suite.controllers.fast_control.control_loop]:
(1,) numpy records of `SKILL_STATE` (the setpoint and the phase's checks,
[Skill.loop_state][tableclean_suite.controllers.skill.Skill.loop_state]) and `WIPE_STATE` (the clean skill's
press-force loop and stroke waypoint, [Wipe.run_loop][tableclean_suite.controllers.clean.Wipe.run_loop]; mode
`MODE_FIXED` for a phase whose waypoint is fixed).
"""

from __future__ import annotations

import numpy as np

#: Phases the control loop runs: a fixed waypoint (the wipe fields unused), the clean's PRESS, WIPE and SHIFT.
MODE_FIXED, MODE_PRESS, MODE_WIPE, MODE_SHIFT = 0, 1, 2, 3

#: The skill's state in the control loop; "updated" fields are written back.
SKILL_STATE = np.dtype([
    ("setpoint", np.float64, (3,)),  # m, the position setpoint (updated)
    ("target", np.float64, (3,)),  # m, the waypoint: a fixed phase's; a wipe phase writes its last step's
    ("yaw_setpoint", np.float64),  # rad, the commanded gripper yaw (updated)
    ("yaw", np.float64),  # rad, the gripper yaw the commanded one turns towards
    ("max_move", np.float64),  # m the setpoint moves per control step
    ("max_turn", np.float64),  # rad the yaw setpoint turns per control step
    ("gripper", np.float64),  # gripper command in [-1, 1]
    ("tolerance", np.float64),  # m of position error under which the phase may complete
    ("gripper_still", np.float64),  # m of finger motion per step under which the fingers are settled
    ("steps", np.int64),  # control steps of the skill so far (updated)
    ("max_steps", np.int64),  # the skill's step budget
    ("phase_steps", np.int64),  # control steps in the current phase (updated)
    ("min_steps", np.int64),  # control steps the phase lasts at least
    ("gripper_timeout", np.int64),  # steps in the phase after which the fingers count as settled (-1: never)
    ("xy_only", np.bool_),  # judge the position error in x and y only
], align=True)

#: The clean skill's wipe in the control loop; "updated" fields are written back.
WIPE_STATE = np.dtype([
    ("stroke", np.float64, (2,)),  # m, the stroke point (x, y)
    ("hold", np.float64, (3,)),  # m, the grip site minus the sponge centre
    ("lift", np.float64, (2,)),  # m, a shift's lift point (x, y)
    ("low", np.float64, (2,)),  # m, the hand's lower x, y bound while wiping
    ("high", np.float64, (2,)),  # m, its upper x, y bound
    ("table_z", np.float64),  # m, the table top
    ("half_z", np.float64),  # m, the sponge's half height
    ("depth", np.float64),  # m, the commanded press depth (updated)
    ("force", np.float64),  # N, the last measured press force (updated)
    ("press_force", np.float64),  # N, the force target
    ("force_gain", np.float64),  # m/(N s), depth rate per N of force error
    ("gap_gain", np.float64),  # 1/s, depth rate per m of gap
    ("contact_slack", np.float64),  # m, the sponge's lowest corner above the table that still counts as on it
    ("dt", np.float64),  # s, the control step
    ("min_depth", np.float64),  # m, the depth's bounds
    ("max_depth", np.float64),
    ("arrival", np.float64),  # m, setpoint height error under which a press has arrived
    ("touch_force", np.float64),  # N, the force that ends a press
    ("drift_bound", np.float64),  # m, the largest lead over the sponge's drift along the stroke
    ("shift_depth", np.float64),  # m, a shift's depth (negative: above the table)
    ("mode", np.int64),  # MODE_FIXED, MODE_PRESS, MODE_WIPE or MODE_SHIFT
    ("axis", np.int64),  # the stroke axis (0: x, 1: y)
    ("stroke_max_steps", np.int64),  # steps after which a stroke's tolerance becomes infinite
    ("press_timeout", np.int64),  # steps after which a press ends without touching
    ("lift_max_steps", np.int64),  # steps after which a shift moves on unlifted
    ("force_fn", np.intp),  # address of the press-force callback (FORCE_CALLBACK), set by the stepper
    ("lifted", np.bool_),  # a shift measured the sponge off the table (updated)
], align=True)


def loop_record(dtype: np.dtype, **fields) -> np.ndarray:
    """A (1,) record array of ``dtype`` with every field given by name.

    Raises ``ValueError`` naming the missing or unknown fields (a field left out would silently be 0).
    """
    if fields.keys() != set(dtype.names):
        missing, unknown = sorted(set(dtype.names) - fields.keys()), sorted(fields.keys() - set(dtype.names))
        raise ValueError(f"loop record fields: missing {missing}, unknown {unknown} (fields: {list(dtype.names)})")
    return np.array([tuple(fields[name] for name in dtype.names)], dtype=dtype)
