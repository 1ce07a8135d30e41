"""Training the next chunks on a thread while the last ones are summarised gives the same bits."""

import numpy as np
import pytest

from tableclean_suite.bench import experiments
from tableclean_suite.bench.config import RunConfig

pytestmark = pytest.mark.quick


def _config(**overrides) -> RunConfig:
    settings = dict(runs=12, iterations=300, learners=("q_learning", "sarsa"), rewards=("r2", "r4"),
                    sweeps=False, literature=False, bootstrap_samples=50, progress=False)
    return RunConfig(**{**settings, **overrides})


def _cells(config: RunConfig):
    return experiments.unique_cells(experiments.config_grid(config))


def _same(a, b) -> bool:
    """Whether two train_cell results hold the same summary and statistics, bit for bit."""
    (summary_a, stats_a, *_), (summary_b, stats_b, *_) = a, b
    curves_a, curves_b = summary_a.curves(), summary_b.curves()
    return (np.array_equal(np.array(list(summary_a.scalars().values()), dtype=float),
                           np.array(list(summary_b.scalars().values()), dtype=float), equal_nan=True)
            and all(curves_a[name].tobytes() == curves_b[name].tobytes() for name in curves_a)
            and all(stats_a.runs[name].tobytes() == stats_b.runs[name].tobytes() for name in stats_a.runs)
            and repr(stats_a.intervals) == repr(stats_b.intervals) and repr(stats_a.scores) == repr(stats_b.scores)
            and repr(stats_a.settling) == repr(stats_b.settling))


@pytest.mark.parametrize("runs_per_chunk", [None, 5])
def test_chunks_trained_ahead_give_the_same_bits(runs_per_chunk, monkeypatch):
    config = _config()
    model = config.task_model()
    cells = _cells(config)
    serial = [experiments.train_cell(cell, config, model, runs_per_chunk=runs_per_chunk) for cell in cells]
    if runs_per_chunk is not None:  # TrainingAhead uses the default chunking: make it this one
        monkeypatch.setattr(experiments, "chunk_runs", lambda *args, **kwargs: runs_per_chunk)
    ahead = experiments.TrainingAhead(cells, config, model)
    try:
        pipelined = [experiments.train_cell(cell, config, model, runs_per_chunk=runs_per_chunk,
                                            chunks=ahead.chunks(cell)) for cell in cells]
    finally:
        ahead.close()
    assert all(_same(a, b) for a, b in zip(serial, pipelined))
    # and the comparison can fail: another cell's results differ
    assert not _same(serial[0], pipelined[1])


def test_a_training_error_is_raised_at_its_cell(monkeypatch):
    config = _config()
    model = config.task_model()
    cells = _cells(config)
    real_train = experiments.train

    def failing(**kwargs):
        if kwargs["learner"] == cells[1].learner and kwargs["reward"] == cells[1].reward:
            raise RuntimeError("boom")
        return real_train(**kwargs)

    monkeypatch.setattr(experiments, "train", failing)
    ahead = experiments.TrainingAhead(cells, config, model)
    try:
        experiments.train_cell(cells[0], config, model, chunks=ahead.chunks(cells[0]))
        with pytest.raises(RuntimeError, match="boom"):
            experiments.train_cell(cells[1], config, model, chunks=ahead.chunks(cells[1]))
    finally:
        ahead.close()


def test_only_table_backends_with_room_train_ahead(monkeypatch):
    config = _config()
    model = config.task_model()
    cells = _cells(config)
    assert experiments.trains_ahead(cells, config, model)
    assert not experiments.trains_ahead(cells[:1], config, model)  # one cell, one chunk: nothing to overlap
    assert not experiments.trains_ahead(cells, _config(backend="physics"), model)
    monkeypatch.setattr(experiments.resources, "available_bytes", lambda: 1)
    assert not experiments.trains_ahead(cells, config, model)


def test_close_stops_and_joins_the_training_thread(monkeypatch):
    config = _config()
    model = config.task_model()
    cells = _cells(config)
    real_train = experiments.train
    calls = []

    def counting(**kwargs):
        calls.append(kwargs["learner"])
        return real_train(**kwargs)

    monkeypatch.setattr(experiments, "train", counting)
    ahead = experiments.TrainingAhead(cells, config, model)
    experiments.train_cell(cells[0], config, model, chunks=ahead.chunks(cells[0]))
    ahead.close()
    assert not ahead.running  # joined: nothing trains once close() has returned
    trained = len(calls)
    assert trained < len(cells)  # it stopped: the later cells were never trained
    ahead.close()  # a second close is harmless
    assert len(calls) == trained


def test_chunks_analysed_where_they_were_trained_give_the_same_bits():
    # TrainingAhead hands a chunk over as trained (the caller analyses it) or with its analysis
    # appended (analysed by the thread): train_cell must give the same bits either way
    from tableclean_suite import asymptotes

    config = _config()
    model = config.task_model()
    cell = _cells(config)[1]
    chain = asymptotes.EpisodeChain.build(model, cell.reward)
    checkpoint = experiments._checkpoint(config)
    assert checkpoint  # the checkpoint asymptotes are part of the analysis
    raw = list(experiments.cell_chunks(cell, config, model, runs_per_chunk=5))
    analysed = [(*item, (*experiments.chunk_analysis(item[1], chain, config, model, checkpoint), 0.0))
                for item in raw]
    mixed = [item if i % 2 else analysed[i] for i, item in enumerate(raw)]
    plain = experiments.train_cell(cell, config, model, runs_per_chunk=5, chunks=iter(raw))
    assert _same(plain, experiments.train_cell(cell, config, model, runs_per_chunk=5, chunks=iter(analysed)))
    assert _same(plain, experiments.train_cell(cell, config, model, runs_per_chunk=5, chunks=iter(mixed)))
