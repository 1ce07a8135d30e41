"""What a result cache keys on: the code that runs and the arrays the learner reads.

Every cache of results (a run's cells, fidelity trials, calibration, the scaling study, tune's
studies, derived results) keys on [code_digest][tableclean_suite.bench.digests.code_digest] and, where
its numbers come from a task model, on [task_digest][tableclean_suite.bench.digests.task_digest]: an
edit to a rule, a reward, a plugin or a plugin's data file then misses the cache instead of serving
numbers computed under the old ones.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Iterable

import numpy as np


def code_digest(plugins: Iterable[str] = ()) -> str:
    """SHA-256 (hex) of the code that runs: the bytes of every Python file of the package (named by
    its path inside the package) and, with ``plugins`` (``--plugins`` entries, imported if they are
    not yet), of each plugin module and every user module it refers to
    ([`loaded_plugin_sources`][tableclean_suite.bench.plugins.loaded_plugin_sources]; by content, so a
    cluster node holding the same code in another folder agrees).

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
    [`TaskModel`][tableclean_suite.task.model.TaskModel]), after its rules and any plugin's actions
    are applied: the transitions (next state and outcome per state and action, ``(S, A)`` int64,
    terminal states mapping to themselves with outcome TERMINAL, which is how a learner tells them)
    and the start states' codes.  Reward values are keyed by value beside it."""
    next_state, outcome = model.transition_arrays()
    starts = np.array([state.index for state in model.start_states()], dtype=np.int64)
    digest = hashlib.sha256()
    for values in (next_state, outcome, starts):
        values = np.ascontiguousarray(values)
        digest.update(f"{values.dtype.str}{values.shape}".encode() + values.tobytes())
    return digest.hexdigest()
