"""Gymnasium environments of the table-cleaning task; importing this package registers their ids:
``TableCleanSymbolic-v0`` (the task model, [`TableCleanSymbolicEnv`][tableclean_suite.gym_envs.symbolic.TableCleanSymbolicEnv]) and
``TableCleanSkills-v0`` (skills in MuJoCo, [`TableCleanSkillsEnv`][tableclean_suite.gym_envs.skills.TableCleanSkillsEnv]).  Both truncate after
500 steps, pickle their ``info`` (vector envs work) and expose ``action_masks()``:

    envs = gymnasium.make_vec("TableCleanSkills-v0", num_envs=2, vectorization_mode="async")
    masks = envs.call("action_masks")
"""

from gymnasium.envs.registration import register, registry

from tableclean_suite.gym_envs.symbolic import MAX_EPISODE_STEPS, TableCleanSymbolicEnv

SYMBOLIC_ID = "TableCleanSymbolic-v0"
SKILLS_ID = "TableCleanSkills-v0"

for _id, _entry_point in (
    (SYMBOLIC_ID, "tableclean_suite.gym_envs.symbolic:TableCleanSymbolicEnv"),
    (SKILLS_ID, "tableclean_suite.gym_envs.skills:TableCleanSkillsEnv"),
):
    if _id not in registry:
        register(id=_id, entry_point=_entry_point, max_episode_steps=MAX_EPISODE_STEPS)


def __getattr__(name):
    """``TableCleanSkillsEnv`` on first access (keeps robosuite out of this package's import)."""
    if name == "TableCleanSkillsEnv":
        from tableclean_suite.gym_envs.skills import TableCleanSkillsEnv

        return TableCleanSkillsEnv
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["SKILLS_ID", "SYMBOLIC_ID", "MAX_EPISODE_STEPS", "TableCleanSymbolicEnv", "TableCleanSkillsEnv"]
