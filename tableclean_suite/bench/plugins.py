"""``--plugins``: import the user's modules that register actions, learners, rewards, specs or objects.

Registries are per process, so a command line cannot see what a user's script registered.
``--plugins my_package.my_module,path/to/extras.py`` imports each entry before the other flags
are checked (a module name, or a path to a ``.py`` file), so every name it registers is allowed
on the command line and listed by ``--help``; executor workers import the same entries before
they train.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from pathlib import Path

#: The flag, and the suffix that marks an entry as a file rather than a module name.
FLAG = "--plugins"
SOURCE_SUFFIX = ".py"


class PluginError(ValueError):
    """A plugin that cannot be imported; the message names it and the reason."""


def split_plugins(text: str | None) -> tuple[str, ...]:
    """``"a.b, c.py"`` -> ``("a.b", "c.py")`` (empty entries dropped, order kept, no repeats)."""
    if not text:
        return ()
    return tuple(dict.fromkeys(part.strip() for part in str(text).split(",") if part.strip()))


def load_plugin(entry: str):
    """Import one plugin: a module name, or a ``.py`` file (imported once per process)."""
    if entry.endswith(SOURCE_SUFFIX):
        path = Path(entry).resolve()
        if not path.is_file():
            raise PluginError(f"plugin {entry!r}: no such file")
        name = f"tableclean_plugin_{path.stem}_{abs(hash(str(path))):x}"
        if name in sys.modules:
            return sys.modules[name]
        spec = importlib.util.spec_from_file_location(name, path)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except Exception as error:  # a plugin may fail in any way; say which and why
            del sys.modules[name]
            raise PluginError(f"plugin {entry!r} failed to import: {type(error).__name__}: {error}") from None
        return module
    try:
        return importlib.import_module(entry)
    except Exception as error:  # as above
        raise PluginError(f"plugin {entry!r} failed to import: {type(error).__name__}: {error}") from None


def load_plugins(entries) -> list:
    """Import every entry in order; :class:`PluginError` names the first that fails."""
    return [load_plugin(entry) for entry in entries]


def preload(argv, prog: str) -> tuple[str, ...]:
    """Import the ``--plugins`` of ``argv`` before the full command line is parsed; exit 2 on failure."""
    early = argparse.ArgumentParser(prog=prog, add_help=False)
    early.add_argument(FLAG, default=None)
    known, _ = early.parse_known_args(argv)
    entries = split_plugins(known.plugins)
    try:
        load_plugins(entries)
    except PluginError as error:
        early.error(f"{FLAG}: {error}")
    return entries
