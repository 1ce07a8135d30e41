"""robosuite environments of tableclean_suite.

Importing this package registers [`TableClean`][tableclean_suite.environments.table_clean.TableClean] with robosuite (robosuite's ``EnvMeta``
registers every environment class when its module is imported), so
``robosuite.make("TableClean", robots="Panda")`` works once ``tableclean_suite`` is imported.
"""

from tableclean_suite.environments.abstraction import AbstractionError, Fault, abstract_state
from tableclean_suite.environments.config import DEFAULT_TABLECLEAN_CONFIG, MAX_SCENE_SEGMENTS, LayoutError
from tableclean_suite.environments.objects import (OBJECT_TYPES, ObjectType, get_object_type, object_type_names,
                                                   register_object)
from tableclean_suite.environments.scene_state import SceneState
from tableclean_suite.environments.table_clean import TableClean

__all__ = ["TableClean", "SceneState", "DEFAULT_TABLECLEAN_CONFIG", "MAX_SCENE_SEGMENTS", "LayoutError", "abstract_state",
           "AbstractionError", "Fault", "OBJECT_TYPES", "ObjectType", "get_object_type", "object_type_names",
           "register_object"]
