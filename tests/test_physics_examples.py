"""The worked examples that extend the physical task from outside the package run to the terminal state."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_custom_object_example_runs_the_optimal_plan_with_a_new_object_type(capsys):
    module = _load("custom_object")
    assert module.main(["--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["terminal"] and all(r["success"] for r in result["rows"])
    assert {"pick", "place"} <= {r["action"] for r in result["rows"]}  # the flat box was moved
    from tableclean_suite.environments import get_object_type

    assert get_object_type("flat_box").yaw_rule is None  # derived: fingers across the narrow side


@pytest.mark.slow
def test_move_back_physics_example_executes_move_back_with_a_registered_skill(capsys):
    module = _load("move_back_physics")
    assert module.main(["--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert "move_back" in result["plan"] and result["terminal"]
    assert all(r["success"] and r["matches_model"] for r in result["rows"])


def test_examples_reject_bad_arguments(capsys):
    for name in ("custom_object", "move_back_physics"):
        with pytest.raises(SystemExit) as exit_info:
            _load(name).main(["--seed", "-1"])
        assert exit_info.value.code == 2 and "--seed" in capsys.readouterr().err
