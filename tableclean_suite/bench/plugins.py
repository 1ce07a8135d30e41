"""``--plugins my_package.my_module,path/to/extras.py``: the user's modules (names or ``.py`` files) that
register actions, learners, rewards, specs or objects, imported before the other flags are checked (so
their names are allowed and listed by ``--help``) and by executor workers before each task."""

from __future__ import annotations

import functools
import importlib
import importlib.util
import sys
from pathlib import Path
from typing import Callable, Iterable, Iterator

FLAG = "--plugins"
SOURCE_SUFFIX = ".py"


class PluginError(ValueError):
    """A plugin that cannot be imported; the message names it and the reason."""


def load_plugin(entry: str):
    """Import one plugin: a module name, or a ``.py`` file (once per process);
    [`PluginError`][tableclean_suite.bench.plugins.PluginError] when it is missing, raises or exits."""
    name = None
    if entry.endswith(SOURCE_SUFFIX):
        path = Path(entry).resolve()
        try:
            if not path.is_file():
                raise PluginError(f"plugin {entry!r}: no such file")
        except OSError as error:  # a folder that cannot be searched, a name too long
            raise PluginError(f"plugin {entry!r}: {error.strerror or error}") from None
        name = f"tableclean_plugin_{path.stem}_{abs(hash(str(path))):x}"
        if name in sys.modules:
            return sys.modules[name]
    try:
        if name is None:
            return importlib.import_module(entry)
        spec = importlib.util.spec_from_file_location(name, path)
        module = sys.modules[name] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    except KeyboardInterrupt:
        raise
    except BaseException as error:  # a plugin may fail (or exit) in any way; say which and why
        sys.modules.pop(name, None)
        how = (f"called sys.exit({error.code!r}) while being imported" if isinstance(error, SystemExit)
               else f"failed to import: {type(error).__name__}: {error}")
        raise PluginError(f"plugin {entry!r} {how}") from None


def load_plugins(entries) -> list:
    """Import every entry in order; [`PluginError`][tableclean_suite.bench.plugins.PluginError] names the
    first that fails."""
    return [load_plugin(entry) for entry in entries]


def portable(entries: Iterable[str]) -> tuple[str, ...]:
    """``entries`` as another process sees them: ``.py`` paths made absolute (a worker may run elsewhere)."""
    return tuple(str(Path(entry).resolve()) if entry.endswith(SOURCE_SUFFIX) else entry for entry in entries)


def _run_with_plugins(plugins: tuple[str, ...], function: Callable, task):
    load_plugins(plugins)
    return function(task)


class PluginExecutor:
    """An executor whose every task first imports the command's plugins in the process that runs it
    (local worker processes and Ray workers alike); everything else is the wrapped executor's."""

    def __init__(self, executor, plugins: Iterable[str]):
        self.executor = executor
        self.plugins = portable(plugins)

    def __getattr__(self, name: str):
        return getattr(self.executor, name)

    def __enter__(self) -> "PluginExecutor":
        self.executor.__enter__()
        return self

    def __exit__(self, *exc_info) -> None:
        self.executor.__exit__(*exc_info)

    def map(self, function: Callable, tasks: Iterable) -> Iterator:
        """``function(task)`` for every task, in task order, each after importing the plugins."""
        from tableclean_suite.executors.base import check_function

        check_function(function)
        return self.executor.map(functools.partial(_run_with_plugins, self.plugins, function), tasks)


def with_plugins(executor, plugins: Iterable[str]):
    """``executor``, wrapped in a [`PluginExecutor`][tableclean_suite.bench.plugins.PluginExecutor] when
    there are ``plugins``."""
    plugins = tuple(plugins or ())
    return PluginExecutor(executor, plugins) if plugins else executor


def _is_user_file(path: str | None) -> bool:
    """Whether ``path`` is a user's source file: not the standard library's, an installed package's or
    ``tableclean_suite``'s (digested apart)."""
    import sysconfig

    if not path or not path.endswith(SOURCE_SUFFIX):
        return False
    resolved = Path(path).resolve()
    package = Path(__file__).resolve().parents[1]
    roots = {Path(p).resolve() for p in (sys.prefix, sys.base_prefix, sys.exec_prefix,
                                         sysconfig.get_paths().get("stdlib"), sysconfig.get_paths().get("purelib"))
             if p}
    return not any(resolved.is_relative_to(root) for root in (*roots, package))


def _user_modules(modules) -> list:
    """``modules`` and every user module their globals refer to (imported, or defining one), transitively."""
    seen, pending = {}, list(modules)
    while pending:
        module = pending.pop()
        path = getattr(module, "__file__", None)
        if not _is_user_file(path) or path in seen:
            continue
        seen[path] = module
        for value in list(vars(module).values()):
            if isinstance(value, type(sys)):
                pending.append(value)
            else:
                owner = sys.modules.get(getattr(value, "__module__", None) or "")
                if owner is not None:
                    pending.append(owner)
    return [seen[path] for path in sorted(seen)]


def loaded_plugin_sources(entries: Iterable[str]) -> dict[str, str]:
    """``{module file: SHA-256 of its bytes}`` of the plugin ``entries`` (imported if need be) and of every user
    module they refer to: what a cache of results computed with them keys on.

    Raises:
        PluginError: an entry cannot be imported.
    """
    import hashlib

    sources = {}
    for module in _user_modules(load_plugins(entries)):
        path = str(Path(module.__file__).resolve())
        sources[path] = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    return sources
