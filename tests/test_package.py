"""The package's import contract: symbolic parts without robosuite; TableClean registered for robosuite users."""

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def python(code: str) -> str:
    result = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    return result.stdout.strip()


def test_symbolic_parts_do_not_import_robosuite():
    code = ("import sys, tableclean_suite.task, tableclean_suite.learners, tableclean_suite.gym_envs; "
            "print('robosuite' in sys.modules, 'mujoco' in sys.modules)")
    assert python(code) == "False False"


def test_table_clean_is_registered_whichever_is_imported_first():
    check = "print('TableClean' in robosuite.environments.base.REGISTERED_ENVS)"
    assert python(f"import tableclean_suite, robosuite; {check}") == "True"
    assert python(f"import robosuite, tableclean_suite; {check}") == "True"
    assert python(f"import robosuite; {check}") == "False"  # the plugin registers only when imported
