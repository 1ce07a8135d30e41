"""A small named registry, shared by reward patterns and learners."""

from __future__ import annotations

import re
from types import MappingProxyType
from typing import Generic, Mapping, TypeVar

T = TypeVar("T")
#: Registry names (task specs, actions, ...): lower_snake.
NAME_PATTERN = re.compile(r"^[a-z][a-z0-9_]*$")


class _Items(dict):
    def __init__(self, kind: str):
        super().__init__()
        self.kind = kind

    def __missing__(self, name):  # (what a view's lookup of an unknown name raises)
        raise KeyError(f"unknown {self.kind} {name!r}; allowed: {', '.join(self)}")


class Registry(Generic[T]):
    """Items of one type under their ``name``; lookups accept a name or an item.

    Args:
        kind: what the items are, for error messages (e.g. ``"reward pattern"``).
        item_type: the class every item must be an instance of.
    """

    def __init__(self, kind: str, item_type: type, items=()):
        self.kind = kind
        self.item_type = item_type
        self._items: dict[str, T] = _Items(kind)
        for item in items:
            self.register(item)

    def register(self, item: T, overwrite: bool = False) -> T:
        """Add ``item`` under ``item.name``; an existing name needs ``overwrite=True``."""
        if not isinstance(item, self.item_type):
            raise TypeError(f"expected a {self.item_type.__name__}, got {type(item).__name__}")
        if item.name in self._items and not overwrite:
            raise ValueError(f"{self.kind} {item.name!r} is already registered; pass overwrite=True to replace it")
        self._items[item.name] = item
        return item

    def names(self) -> list[str]:
        """Registered names, in registration order."""
        return list(self._items)

    def view(self) -> Mapping[str, T]:
        """A read-only, live ``name -> item`` mapping of the registry (``KeyError`` naming the registered names for
        an unknown one)."""
        return MappingProxyType(self._items)

    def get(self, key: str | T) -> T:
        """The item registered as ``key``, or ``key`` itself when it is an item; clear error otherwise."""
        if isinstance(key, self.item_type):
            return key
        if isinstance(key, str) and key in self._items:
            return self._items[key]
        allowed = ", ".join(self._items)
        raise ValueError(f"unknown {self.kind} {key!r}; allowed: {allowed} or a {self.item_type.__name__}")
