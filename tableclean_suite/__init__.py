"""tableclean_suite: task-level RL for a two-segment table-cleaning scenario, on robosuite.

Importing the package registers the ``TableClean`` environment with robosuite, so
``robosuite.make("TableClean", robots="Panda")`` works in any project.
"""

from tableclean_suite.task import Action, Outcome, TaskModel, TaskState  # noqa: F401
from tableclean_suite import environments  # noqa: F401  (registers TableClean with robosuite)
from tableclean_suite import gym_envs  # noqa: F401  (registers the Gymnasium ids)

__version__ = "0.1.0"
