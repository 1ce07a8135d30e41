""":class:`~tableclean_suite.environments.skill_info.SkillInfo`, the dict ``TableClean.skill_info()`` returns:
lazy keys computed once on first read, seen by every whole-dict operation, refused once the simulation advanced."""

from __future__ import annotations

import pickle

import pytest

from tableclean_suite.environments.skill_info import SkillInfo, StaleSkillInfoError


class Owner:
    """A stand-in env: a clock and a count of the fills."""

    def __init__(self):
        self.time = 0.0
        self.fills = 0

    def clock(self) -> float:
        return self.time

    def fill_pair(self, info: SkillInfo) -> None:
        self.fills += 1
        info["a"] = self.time + 1.0
        info["b"] = self.time + 2.0


def make(owner: Owner) -> SkillInfo:
    lazy = {"a": Owner.fill_pair, "b": Owner.fill_pair}
    return SkillInfo.create({"x": 1}, owner, lazy, owner.clock)


def test_a_lazy_group_is_filled_once_on_first_read():
    owner = Owner()
    info = make(owner)
    assert owner.fills == 0 and dict.__len__(info) == 1
    assert info["a"] == 1.0 and info["b"] == 2.0 and info.get("b") == 2.0
    assert owner.fills == 1


def test_whole_dict_operations_see_every_key():
    owner = Owner()
    assert "a" in make(owner) and "z" not in make(owner)
    assert len(make(owner)) == 3
    assert sorted(make(owner)) == ["a", "b", "x"]
    assert dict(make(owner)) == {"x": 1, "a": 1.0, "b": 2.0} == {**make(owner)}
    assert make(owner) == {"x": 1, "a": 1.0, "b": 2.0} and make(owner) == make(owner)
    assert make(owner).copy() == {"x": 1, "a": 1.0, "b": 2.0} and type(make(owner).copy()) is dict
    assert pickle.loads(pickle.dumps(make(owner))) == {"x": 1, "a": 1.0, "b": 2.0}
    assert "'a': 1.0" in repr(make(owner))


def test_missing_keys_and_removals_behave_as_a_dict():
    owner = Owner()
    info = make(owner)
    assert info.get("z", 5) == 5
    with pytest.raises(KeyError):
        info["z"]
    assert info.pop("a") == 1.0 and "a" not in info and info.pop("a", None) is None
    del info["b"]
    assert "b" not in info and dict(info) == {"x": 1}
    info["a"] = 7.0  # set by the caller: kept
    assert info["a"] == 7.0


def test_a_lazy_key_read_after_the_simulation_advanced_is_refused():
    owner = Owner()
    info = make(owner)
    owner.time = 0.002
    with pytest.raises(StaleSkillInfoError, match="'a'.*skill_info\\(\\) again"):
        info["a"]
    assert make(owner)["a"] == 1.002  # a new one reads the new state
