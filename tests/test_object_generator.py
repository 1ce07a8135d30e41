"""Generated objects: reproducible MJCF, every one accepted by register_object and the scene's checks."""

import csv
from types import SimpleNamespace

import pytest

from tableclean_suite.environments.object_generator import FEATURES, ObjectRanges, random_objects
from tableclean_suite.environments.objects import (BUILTIN_OBJECTS, check_holdable, register_object, type_geometry)

#: The open Panda gripper's pad gap [m] (measured from its model; docs/objects-and-skills.md).
PANDA_OPEN_WIDTH = 0.079


def test_same_seed_gives_the_same_mjcf_and_each_object_is_independent_of_the_count():
    first = [kind.build.mjcf for kind in random_objects(8, seed=3)]
    assert first == [kind.build.mjcf for kind in random_objects(8, seed=3)]
    assert first[:5] == [kind.build.mjcf for kind in random_objects(5, seed=3)]
    assert first != [kind.build.mjcf for kind in random_objects(8, seed=4)]
    assert len(set(first)) == 8


def test_every_generated_object_registers_and_passes_the_scenes_checks():
    kinds = random_objects(60, seed=0)
    tallest = max(type_geometry(kind.name, {"object_half_size": (0.0225,) * 3}).height for kind in BUILTIN_OBJECTS)
    ranges = ObjectRanges()
    seen = set()
    for kind in kinds:
        register_object(kind, overwrite=True)
        shape = type_geometry(kind.name, {})
        check_holdable(kind.name, shape, PANDA_OPEN_WIDTH)
        assert ranges.width[0] - 1e-3 <= shape.narrow_width <= ranges.width[1] + 1e-4, kind.description
        assert ranges.height[0] - 1e-4 <= shape.height <= tallest + 1e-4, kind.description
        assert 2 * shape.footprint_radius <= ranges.span + ranges.width[1] + 1e-3, kind.description
        assert abs(shape.lower[2] + shape.height / 2) < 1e-4  # origin at mid-height, as robosuite's objects
        seen |= {kind.build.params["body"], *kind.build.params["features"]}
    assert seen == set(FEATURES) | {f for fs in FEATURES.values() for f in fs}


@pytest.mark.parametrize("n, seed", [(-1, 0), (2, -1), (1.5, 0)])
def test_bad_count_or_seed_is_refused_naming_it(n, seed):
    with pytest.raises(ValueError, match="must be an int >= 0"):
        random_objects(n, seed)


def test_a_failure_is_classified_by_its_phase_and_cause_with_numbers_generalised():
    from tableclean_suite.bench.object_table import failure_class

    result = SimpleNamespace(final_phase="DESCEND", reason="step budget of 250 exhausted in phase DESCEND")
    assert failure_class(result) == ("DESCEND", "step budget of N exhausted in phase DESCEND")
    result = SimpleNamespace(final_phase="CLOSE", reason="CLOSE: grasp not confirmed")
    assert failure_class(result) == ("CLOSE", "grasp not confirmed")
    result = SimpleNamespace(final_phase="DONE", reason="fault: object 1 at xy=(-0.003, 0.119) lies on no segment")
    assert failure_class(result) == ("DONE", "fault: object N at xy=(N, N) lies on no segment")
    result = SimpleNamespace(final_phase="DONE", reason="ended in S1:unclean+o1 | arm@S1, expected S1:unclean | arm@S1 holding o1")
    assert failure_class(result) == ("DONE", "ended in a state other than the model's successor")


#: The paper's actions, as failure rows name them.
ACTIONS = {"move", "pick", "place", "clean"}


def test_a_failed_random_episode_is_one_row_naming_its_start_history_skill_phase_and_cause(monkeypatch):
    from tableclean_suite.bench import fidelity, object_table

    kind = random_objects(1, seed=2)[0]
    register_object(kind, overwrite=True)
    env = SimpleNamespace(set_start_state=lambda state: None, reset=lambda: None)

    def play(count, plan_of, model, *args, **kwargs):
        plan = plan_of(env, model, 0)
        moved = SimpleNamespace(action=plan[0], success=True, retries=0)
        failed = SimpleNamespace(action=plan[1], success=False, retries=1, final_phase="CLOSE",
                                 reason="CLOSE: gap of 0.012 m")
        return {"episodes": 1, "successes": 0, "skills": {}, "failures": [(0, "-", [moved, failed])]}

    monkeypatch.setattr(fidelity, "play_episodes", play)
    rows, (failure,) = object_table.run_random(kind, 0, 1, 2, "box")
    assert rows == [] and failure["object"] == kind.name and failure["params"] == kind.description
    assert failure["episode"] == 0 and failure["start"] and {failure["history"], failure["skill"]} <= ACTIONS
    assert (failure["phase"], failure["cause"], failure["retries"]) == ("CLOSE", "gap of N m", 1)


@pytest.mark.slow
def test_random_objects_are_measured_in_random_episodes_and_an_all_refused_run_exits_non_zero(tmp_path, capsys):
    from robosuite.models.objects import BoxObject

    from tableclean_suite.bench import object_table

    assert object_table.main(["--random", "1", "--episodes", "1", "--seed", "2", "--out", str(tmp_path)],
                             prog="objects") == 0
    out = capsys.readouterr().out
    rows = list(csv.DictReader((tmp_path / object_table.TABLE_CSV).open()))
    assert {row["object"] for row in rows} == {"gen2_0", "random objects (1)"}
    assert sum(int(row["executions"]) for row in rows if row["object"] == "gen2_0") >= 1
    assert "[1/1] gen2_0 (" in out and "| random objects (1) | random | box |" in out
    assert (tmp_path / object_table.FAILURES_CSV).exists()

    register_object("too_wide_slab", lambda name: BoxObject(name=name, size=[0.05, 0.05, 0.02]), overwrite=True)
    assert object_table.main(["--objects", "too_wide_slab", "--settings", "alone", "--episodes", "1", "--out",
                              str(tmp_path / "refused")], prog="objects") == 1
    assert "cannot be grasped" in capsys.readouterr().out
