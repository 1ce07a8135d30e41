"""tableclean_suite: task-level RL for table cleaning, as a robosuite plugin and benchmark suite.

Importing the package makes ``TableClean`` available to robosuite:
``robosuite.make("TableClean", robots="Panda")`` works in any project that imported
``tableclean_suite``.  The environment module is imported when robosuite is (at once
if robosuite is already loaded, otherwise by a post-import hook), so the symbolic parts
(task, learners, harness) start without paying for robosuite and MuJoCo.
"""

import wrapt

from tableclean_suite.task import Action, Outcome, TaskModel, TaskSpec, TaskState  # noqa: F401
from tableclean_suite import gym_envs  # noqa: F401  (registers the Gymnasium ids)

__version__ = "0.2.0"

#: The module whose import registers ``TableClean`` with robosuite (robosuite's EnvMeta).
ENVIRONMENTS_MODULE = "tableclean_suite.environments"


@wrapt.when_imported("robosuite")
def _register_with_robosuite(robosuite_module):
    """Import the environments (registering ``TableClean``) as soon as robosuite is imported."""
    import importlib

    importlib.import_module(ENVIRONMENTS_MODULE)
