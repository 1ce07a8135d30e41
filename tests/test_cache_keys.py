"""A stored cell is resumed only when what determines its numbers is unchanged: the arrays the
learner reads (transitions, start states, rewards per outcome) and the code that runs (the
package's and the plugins'), so an edited rule, reward, plugin or plugin data file trains again."""

import json
import textwrap

import numpy as np

from tableclean_suite.bench import digests, experiments
from tableclean_suite.bench.config import RunConfig
from tableclean_suite.bench.plugins import load_plugins
from tableclean_suite.rewards import RewardPattern
from tableclean_suite.task import Outcome, TaskModel, batch_rules

SMALL = dict(runs=3, iterations=60, learners=("q_learning",), rewards=("r4",), sweeps=False, literature=False,
             bootstrap_samples=10)

PLUGIN = textwrap.dedent("""
    import json
    from pathlib import Path

    from tableclean_suite.task import ActionRule, Outcome, TaskSpec, register_action, register_task_spec

    DATA = Path(__file__).with_name("{name}.json")

    def shift(state):
        step = json.loads(DATA.read_text())["step"]  # the data file decides where the arm goes
        return state.replace(arm=(state.arm + step) % state.n_segments), Outcome.ROUTINE

    register_action(ActionRule("{name}_shift", shift), overwrite=True)
    register_task_spec(TaskSpec("{name}_spec", segments=3, actions=("move", "{name}_shift", "pick", "place", "clean")),
                       overwrite=True)
""")


def _run(config: RunConfig, store, model=None):
    """``(trained, resumed)`` of a run of ``config`` into ``store`` (a rerun into the same ``--out``)."""
    outcome = experiments.run_grid(experiments.config_grid(config), config, model or config.task_model(), store)
    return outcome.trained, outcome.resumed


def test_an_edited_rule_misses_the_cache(tmp_path, monkeypatch):
    config, store = RunConfig(**SMALL), experiments.CellStore(tmp_path)
    assert _run(config, store) == (1, 0)
    assert _run(config, store) == (0, 1)  # nothing changed: resumed
    built_in = batch_rules.batch_step

    def edited(digits, rule, improper):  # cleaning a dirty segment now counts as cleaning a clean one
        next_codes, outcome, raw = built_in(digits, rule, improper)
        return next_codes, np.where(outcome == Outcome.RELEVANT_CLEAN, Outcome.IRRELEVANT_CLEAN, outcome), raw

    monkeypatch.setattr(batch_rules, "batch_step", edited)
    assert _run(config, store) == (1, 0)


def test_an_edited_reward_misses_the_cache(tmp_path, monkeypatch):
    config, store = RunConfig(**SMALL), experiments.CellStore(tmp_path)
    assert _run(config, store) == (1, 0)
    values = RewardPattern.outcome_values
    monkeypatch.setattr(RewardPattern, "outcome_values", lambda pattern: values(pattern) * 2)
    assert _run(config, store) == (1, 0)


def test_an_edited_plugin_data_file_or_source_misses_the_cache(tmp_path, monkeypatch):
    name = f"keys_{tmp_path.name.replace('-', '_')}"
    plugin, data = tmp_path / f"{name}.py", tmp_path / f"{name}.json"
    plugin.write_text(PLUGIN.format(name=name))
    data.write_text(json.dumps({"step": 1}))
    load_plugins([str(plugin)])
    config = RunConfig(**SMALL, task=f"{name}_spec", plugins=(str(plugin),))
    store = experiments.CellStore(tmp_path / "cells")
    assert _run(config, store) == (1, 0)
    assert _run(config, store) == (0, 1)
    before = digests.task_digest(config.task_model())
    data.write_text(json.dumps({"step": 2}))  # only the data file changes: other transitions
    assert digests.task_digest(config.task_model()) != before
    assert _run(config, store) == (1, 0)
    code = digests.code_digest(config.plugins)
    plugin.write_text(plugin.read_text() + "\n# edited\n")  # the plugin's source changes, its arrays do not
    assert digests.code_digest(config.plugins) != code
    assert _run(config, store) == (1, 0)
