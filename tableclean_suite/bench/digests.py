"""What a result cache keys on: the code that runs and the arrays the learner reads, so that an edit to a
rule, a reward or a plugin misses the cache instead of serving numbers computed under the old ones."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Iterable

import numpy as np


def code_digest(plugins: Iterable[str] = ()) -> str:
    """SHA-256 (hex) of the code that runs: every Python file of the package (by its path inside it) and the
    ``plugins`` with the user modules they refer to, by content
    ([`loaded_plugin_sources`][tableclean_suite.bench.plugins.loaded_plugin_sources]).

    Raises:
        tableclean_suite.bench.plugins.PluginError: a plugin cannot be imported.
    """
    import tableclean_suite

    digest = hashlib.sha256()
    root = Path(tableclean_suite.__file__).parent
    for path in sorted(root.rglob("*.py")):
        digest.update(str(path.relative_to(root)).encode() + b"\0" + path.read_bytes())
    plugins = tuple(plugins or ())
    if plugins:
        from tableclean_suite.bench.plugins import loaded_plugin_sources

        digest.update("".join(sorted(loaded_plugin_sources(plugins).values())).encode())
    return digest.hexdigest()


def task_digest(model) -> str:
    """SHA-256 (hex) of the arrays a learner reads from ``model`` (a
    [`TaskModel`][tableclean_suite.task.model.TaskModel]): the ``(S, A)`` transitions (next state,
    outcome) and the start states' codes.  Reward values are keyed apart."""
    next_state, outcome = model.transition_arrays()
    starts = np.array([state.index for state in model.start_states()], dtype=np.int64)
    digest = hashlib.sha256()
    for values in (next_state, outcome, starts):
        values = np.ascontiguousarray(values)
        digest.update(f"{values.dtype.str}{values.shape}".encode() + values.tobytes())
    return digest.hexdigest()
