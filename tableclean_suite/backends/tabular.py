"""Table-driven backends: the task model's transitions (``symbolic``) or measured ones (``calibrated``).

Both step a [`TransitionTable`][tableclean_suite.learners.transitions.TransitionTable], either with the compiled
batched loop ([`tableclean_suite.learners.kernel`][tableclean_suite.learners.kernel], chunks of runs) or one step at a time from Python
([`stepper`][tableclean_suite.learners.stepper], ``engine="reference"``); the two give identical arrays.

Double Q-learning's result ``q`` is the average of its two tables; both are in ``info["double_q_tables"]``,
shape ``(R, 2, S, A)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tableclean_suite import resources
from tableclean_suite.learners.memory import learner_training_memory
from tableclean_suite.backends import CHECKPOINT_Q, BackendRecords, TrainingJob
from tableclean_suite.learners import assist, kernel, optimality, stepper
from tableclean_suite.learners.stepper import DOUBLE_Q_TABLES, RECORD_FIELDS
from tableclean_suite.learners.rng import run_keys
from tableclean_suite.learners.rules import METHOD_DOUBLE_Q, TIES
from tableclean_suite.learners.threads import run_in_threads
from tableclean_suite.learners.transitions import TransitionTable

#: Runs per call of the compiled loop (slices of them trained on ``numba.get_num_threads()`` threads by
#: [`run_in_threads`][tableclean_suite.learners.threads.run_in_threads]); only affects progress granularity and
#: memory, never the numbers.
RUNS_PER_CHUNK = 256


def progress_bar(iterable, enabled: bool, description: str):
    """``iterable`` wrapped in a tqdm bar on stderr when ``enabled``."""
    if not enabled:
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, desc=description, leave=False)


def check_job_resources(job: TrainingJob, measured: bool) -> None:
    """Refuse ``job`` before allocating when it cannot fit or would run too long (every update
    counted, Dyna-Q's planning ones too; see [`tableclean_suite.resources`][tableclean_suite.resources])."""
    model = job.model
    successors = job.options["transitions"].max_successors if measured else 1
    what = (f"training {job.learner.name!r} on task {model.spec.name!r} ({model.n_states} states x "
            f"{model.n_actions} actions, {job.runs} runs x {job.iterations} iterations)")
    resources.require_memory(learner_training_memory(
        model, job.learner, job.runs, job.iterations, checkpoint=job.checkpoint > 0, engine=job.engine,
        max_successors=successors), what)
    resources.require_training_time(job.runs, job.iterations, model.n_states, model.n_actions, what, job.engine,
                                    job.learner.planning_steps, 2 if job.learner.method == METHOD_DOUBLE_Q else 1)


@dataclass(frozen=True)
class TableBackend:
    """Train on a transition table: the model's own (``symbolic``) or a measured one (``calibrated``)."""

    name: str
    measured: bool
    #: Training the first k iterations reproduces the first k iterations of a longer run bit for bit
    #: (counter-based random numbers), cheaply enough to replay (the harness's settling check).
    deterministic_prefix: bool = True

    def check_options(self, model, options: dict) -> dict:
        """``calibrated`` needs ``transitions`` (a table or a JSON path, validated against the model)."""
        unknown = sorted(set(options) - {"transitions"})
        if unknown:
            raise ValueError(f"backend {self.name!r}: unknown option(s) {unknown}; allowed: 'transitions'")
        transitions = options.get("transitions")
        if not self.measured:
            if transitions is not None:
                raise ValueError("transitions= is only used with backend='calibrated'")
            return {}
        if transitions is None:
            raise ValueError("backend='calibrated' needs transitions= (a TransitionTable or a JSON path)")
        if not isinstance(transitions, TransitionTable):
            transitions = TransitionTable.from_json(transitions, model)
        transitions.check_model(model)
        return {"transitions": transitions}

    def train(self, job: TrainingJob) -> BackendRecords:
        """Run ``job`` on the table with the compiled or the reference loop.

        Raises [`ResourceError`][tableclean_suite.resources.ResourceError] (before allocating) when its
        records, Q-tables and tables would not fit in the available memory, or its steps would
        take longer than `MAX_TRAINING_SECONDS`; then
        [`UnlearnableTaskError`][tableclean_suite.task.model.UnlearnableTaskError] when no terminal state
        can be reached from a start state of the task.
        """
        check_job_resources(job, self.measured)
        job.model.require_learnable()
        table = job.options["transitions"] if self.measured else TransitionTable.from_model(job.model)
        config = {"transitions": table.source} if self.measured else {}
        if job.engine == "reference":
            env = stepper.TableStepEnv(job.model, table)
            per_run = [stepper.train_run(env, job.learner, job.reward, job.iterations, seed=job.seed,
                                         run=job.first_run + r, checkpoint=job.checkpoint, **job.hyperparameters)
                       for r in progress_bar(range(job.runs), job.progress, "runs")]
            records = {name: np.stack([run[name] for run in per_run])
                       for name in (*RECORD_FIELDS, "q", "first_learned_at", "learned_at")}
            info = {name: np.stack([run[name] for run in per_run]) for name in (DOUBLE_Q_TABLES, CHECKPOINT_Q)
                    if name in per_run[0]}
            return BackendRecords(**records, config=config, info=info)
        model = job.model
        learner = job.learner
        records = {name: np.zeros((job.runs, job.iterations), np.float64 if name == "rewards" else model.record_dtype)
                   for name in RECORD_FIELDS}
        q = np.full((job.runs, model.n_states, model.n_actions), learner.q_init, dtype=np.float64)
        double = learner.method == METHOD_DOUBLE_Q
        q_second = np.full(q.shape if double else (job.runs, 0, 0), learner.q_init, dtype=np.float64)
        keys = run_keys(job.seed, job.first_run, job.runs)
        starts, task_next, distance = optimality.task_arrays(model)
        first_learned = np.full(job.runs, optimality.NOT_LEARNED, dtype=np.int64)
        learned = np.full(job.runs, optimality.NOT_LEARNED, dtype=np.int64)
        values = job.reward.outcome_values()
        loop_value = 0.0 if job.reward.looping_penalty is None else job.reward.looping_penalty
        learner_parameters = learner.kernel_parameters()
        explore_parameters = learner.exploration.kernel_parameters(job.epsilon)
        afforded, advisor = assist.assistance_arrays(learner, model)
        advice = learner.advice_parameters()
        train_batch = kernel.kernel_for(learner)
        snapshot_at = job.checkpoint if 0 < job.checkpoint <= job.iterations else kernel.NO_SNAPSHOT
        q_snapshot = np.zeros(q.shape if snapshot_at != kernel.NO_SNAPSHOT else (job.runs, 0, 0))
        q_second_snapshot = np.zeros(q_second.shape if snapshot_at != kernel.NO_SNAPSHOT else (job.runs, 0, 0))
        for lo in progress_bar(range(0, job.runs, RUNS_PER_CHUNK), job.progress, f"{learner.name}/{job.reward.name}"):
            hi = min(lo + RUNS_PER_CHUNK, job.runs)
            run_in_threads(train_batch, hi - lo, (
                table.next_state, table.outcome, table.cumulative, starts, values, loop_value, job.reward.looping_code,
                job.reward.looping_memory,
                learner.target_code, learner.on_policy, learner.method, learner_parameters, job.alpha, job.gamma,
                learner.exploration.code, explore_parameters, learner.affordance_code, afforded, advisor, advice,
                job.max_itr, TIES[learner.ties], task_next, distance,
                keys[lo:hi], q[lo:hi], q_second[lo:hi], *(records[name][lo:hi] for name in RECORD_FIELDS),
                snapshot_at, q_snapshot[lo:hi], q_second_snapshot[lo:hi], first_learned[lo:hi], learned[lo:hi],
            ))
        info = {}
        if snapshot_at != kernel.NO_SNAPSHOT:
            info[CHECKPOINT_Q] = (q_snapshot + q_second_snapshot) * kernel.HALF if double else q_snapshot
        learning = {"first_learned_at": first_learned, "learned_at": learned}
        if double:
            return BackendRecords(**records, q=(q + q_second) * kernel.HALF, config=config,
                                  info={DOUBLE_Q_TABLES: np.stack((q, q_second), axis=1), **info}, **learning)
        return BackendRecords(**records, q=q, config=config, info=info, **learning)


SYMBOLIC = TableBackend("symbolic", measured=False)
CALIBRATED = TableBackend("calibrated", measured=True)
