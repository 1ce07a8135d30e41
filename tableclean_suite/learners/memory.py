"""Memory a learner's training allocates, for the guard of [`tableclean_suite.resources`][tableclean_suite.resources]:
double Q's tables, traces, Dyna's model, learned affordance masks, visit counts, the looping memory, the greedy walk."""

from __future__ import annotations

import numba

from tableclean_suite import resources
from tableclean_suite.learners.assist import AFFORD_LEARNED
from tableclean_suite.learners.exploration import VISIT_DECAY_CODE
from tableclean_suite.learners.rules import METHOD_DOUBLE_Q, METHOD_DYNA, METHOD_TRACES


#: Per state, the iteration it was last entered (int64): the looping rule's memory.
LOOPING_MEMORY_WORDS = 1
#: Per state, the greedy walk's examined states and greedy actions (int64 each) and flags (one byte):
#: every run's learning time ([`tableclean_suite.learners.optimality`][tableclean_suite.learners.optimality]).
GREEDY_WALK_WORDS = 2
GREEDY_WALK_FLAG_BYTES = 1


def run_working_bytes(learner, n_states: int, n_actions: int) -> int:
    """Bytes of one run's working arrays in the compiled loop (``kernel.run_memory``) for ``learner`` (a
    ``TabularLearner``): eligibility traces, Dyna's model, learned affordance masks, visit counts (S int64),
    the states' entry times of the looping rule (S int64) and the greedy walk's arrays (17 bytes per state)."""
    per_pair = {METHOD_TRACES: resources.TRACE_BYTES_PER_PAIR,
                METHOD_DYNA: resources.DYNA_BYTES_PER_PAIR}.get(learner.method, 0)
    if learner.affordance_code == AFFORD_LEARNED:
        per_pair += resources.LEARNED_AFFORDANCE_BYTES_PER_PAIR
    per_state_words = int(learner.exploration.code == VISIT_DECAY_CODE)
    per_state_words += GREEDY_WALK_WORDS + LOOPING_MEMORY_WORDS
    return (int(n_states) * int(n_actions) * per_pair + int(n_states) * per_state_words * resources.WORD_BYTES
            + int(n_states) * GREEDY_WALK_FLAG_BYTES)


def learner_training_memory(model, learner, runs: int, iterations: int, checkpoint: bool = False,
                            engine: str = resources.DEFAULT_ENGINE,
                            max_successors: int = 1) -> resources.MemoryEstimate:
    """[`tableclean_suite.resources.training_memory`][tableclean_suite.resources.training_memory] of ``train()``-ing ``learner`` (a
    ``TabularLearner``) on ``model`` (a ``TaskModel``), whatever the reward pattern: two
    tables per run for double Q-learning, the learner's run working memory
    ([`run_working_bytes`][tableclean_suite.learners.memory.run_working_bytes]) in each of numba's threads.
    """
    return resources.training_memory(
        model.n_states, model.n_actions, runs, iterations, q_tables=2 if learner.method == METHOD_DOUBLE_Q else 1,
        max_successors=max_successors, code_bytes=model.record_dtype.itemsize, checkpoint=checkpoint, engine=engine,
        run_bytes=run_working_bytes(learner, model.n_states, model.n_actions),
        concurrent_runs=numba.get_num_threads())
