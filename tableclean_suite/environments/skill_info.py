"""The mapping ``TableClean.skill_info()`` returns: a dict whose costlier per-step values are read on first use.

The skills read ``skill_info()`` every control step but most phases use a few of its keys: the
grip site's orientation (robosuite's ``mat2quat``, an eigen-decomposition) only when a phase may
end, the grasp flags (a pass over the contacts) only while travelling or grasping, the dirt and
velocities only in the abstraction.  :class:`SkillInfo` is a ``dict`` (reads of present keys run
at dict speed) holding the cheap values; each *lazy* key is computed by its owner's function on
the first read (``info[key]``, ``info.get(key)``) and stored.  ``key in info``, ``len``, iteration,
``keys()``/``items()``/``values()``, ``==``, ``copy()``, ``dict(info)``, ``repr`` and pickling see
every key (whole-dict operations compute the missing ones first), so it behaves as the plain dict
it replaces.

The values are those of the simulation state at the call: a lazy key read after the simulation
time advanced raises :class:`StaleSkillInfoError` (call ``skill_info()`` again) rather than mixing
two states.
"""

from __future__ import annotations

from typing import Any, Callable, Mapping

#: A lazy key's function: ``fill(owner, info)`` stores that key (and any others it computes alike) in ``info``.
Filler = Callable[[Any, "SkillInfo"], None]


class StaleSkillInfoError(RuntimeError):
    """A lazy key of a :class:`SkillInfo` was read after the simulation it describes advanced."""


class SkillInfo(dict):
    """``skill_info()``'s dict: present keys as a dict, the keys of ``lazy`` computed on first read.

    Build with :meth:`create`.  ``lazy`` maps each lazy key to its filler (see :data:`Filler`);
    ``owner`` is passed to the fillers, and ``clock()`` (a comparable stamp of the simulation state, e.g.
    its time [s], or the env's ``(state writes, time)``) must still return ``stamp`` when a lazy key is
    computed.
    """

    __slots__ = ("_owner", "_lazy", "_clock", "_stamp")

    @classmethod
    def create(cls, values: Mapping[str, Any], owner: Any, lazy: Mapping[str, Filler],
               clock: Callable[[], Any], stamp: Any = None) -> "SkillInfo":
        """A mapping of ``values`` (copied shallowly) plus ``lazy``'s keys, stamped with ``clock()``.

        ``stamp``: ``clock()``'s value now when the caller has it at hand (None: ``clock()`` is called)."""
        info = cls(values)
        info._owner, info._lazy, info._clock, info._stamp = owner, lazy, clock, clock() if stamp is None else stamp
        return info

    def __missing__(self, key):
        fill = self._lazy.get(key)
        if fill is None:
            raise KeyError(key)
        now = self._clock()
        if now != self._stamp:
            raise StaleSkillInfoError(f"skill_info key {key!r} read at simulation state {now} from a skill_info() "
                                      f"of state {self._stamp}; call skill_info() again")
        fill(self._owner, self)
        return dict.__getitem__(self, key)

    def _pending(self) -> list[str]:
        """The lazy keys not computed (nor set, nor deleted) yet."""
        return [key for key in self._lazy if not dict.__contains__(self, key)]

    def materialize(self) -> "SkillInfo":
        """Compute every lazy key not computed yet; returns ``self``."""
        for key in self._pending():
            if not dict.__contains__(self, key):  # a filler may have stored it with an earlier one
                self[key]
        return self

    def _forget(self, key) -> None:
        """``key`` was removed: it is no lazy key of this mapping any more."""
        if key in self._lazy:
            self._lazy = {k: fill for k, fill in self._lazy.items() if k != key}

    # -- lookups that must see the lazy keys --------------------------------------------------
    def __contains__(self, key) -> bool:
        return dict.__contains__(self, key) or key in self._lazy

    def get(self, key, default=None):
        return self[key] if key in self else default

    def setdefault(self, key, default=None):
        if key in self:
            return self[key]
        self[key] = default
        return default

    # -- whole-dict operations: every key computed first --------------------------------------
    def __iter__(self):
        return dict.__iter__(self.materialize())

    def __reversed__(self):
        return dict.__reversed__(self.materialize())

    def __len__(self) -> int:
        return dict.__len__(self.materialize())

    def keys(self):
        return dict.keys(self.materialize())

    def items(self):
        return dict.items(self.materialize())

    def values(self):
        return dict.values(self.materialize())

    def copy(self) -> dict:
        """A plain ``dict`` of every key."""
        return dict(dict.items(self.materialize()))

    def __eq__(self, other) -> bool:
        if isinstance(other, SkillInfo):
            other.materialize()
        return dict.__eq__(self.materialize(), other)

    def __ne__(self, other) -> bool:
        equal = self.__eq__(other)
        return equal if equal is NotImplemented else not equal

    __hash__ = None

    def __or__(self, other):
        return self.copy() | other

    def __ror__(self, other):
        return other | self.copy()

    def __repr__(self) -> str:
        return dict.__repr__(self.materialize())

    def __reduce__(self):
        return dict, (self.copy(),)

    # -- removals -------------------------------------------------------------------------------
    def __delitem__(self, key) -> None:
        if key in self:
            self[key]
        dict.__delitem__(self, key)
        self._forget(key)

    def pop(self, key, *default):
        if key in self:
            value = self[key]
            dict.__delitem__(self, key)
            self._forget(key)
            return value
        if default:
            return default[0]
        raise KeyError(key)

    def popitem(self):
        item = dict.popitem(self.materialize())
        self._forget(item[0])
        return item

    def clear(self) -> None:
        dict.clear(self)
        self._lazy = {}
