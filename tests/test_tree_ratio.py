"""``tableclean-bench speed --old-tree DIR``: the run command's whole process here against an older
tree, in alternating pairs, as ratios (:mod:`tableclean_suite.bench.tree_ratio`)."""

from pathlib import Path

import pytest

from tableclean_suite.bench import speed, tree_ratio


def _recording_timer(seconds):
    """A timer returning ``seconds`` in turn and recording ``(tree, out, cache_dir)`` of each call."""
    calls, values = [], iter(seconds)

    def timer(tree, out, cache_dir):
        calls.append((tree, out, cache_dir))
        return next(values)

    return timer, calls


@pytest.mark.quick
def test_the_trees_alternate_and_each_pair_gives_a_ratio():
    ours, theirs = Path("/ours"), Path("/theirs")
    timer, calls = _recording_timer([9.0, 9.0, 2.0, 8.0, 5.0, 10.0, 3.0, 10.0])  # two warm-up runs, then 3 pairs
    times = tree_ratio.paired_times("default run", ours, theirs, pairs=3, timer=timer)
    assert [tree for tree, _, _ in calls] == [ours, theirs] * 4
    assert all(cache is None for _, _, cache in calls)  # the trees' own (warm) kernel caches
    assert len({out for _, out, _ in calls}) == len(calls)  # a new output directory every run: no result cache
    assert times.ours == (2.0, 5.0, 3.0) and times.theirs == (8.0, 10.0, 10.0)
    assert times.ratios == (0.25, 0.5, 0.3) and times.ratio == 0.3
    assert "median 0.300" in times.line()


@pytest.mark.quick
def test_a_cold_pair_gives_every_run_a_new_empty_kernel_cache_and_no_warm_up():
    timer, calls = _recording_timer([4.0, 10.0, 4.0, 12.0])
    times = tree_ratio.paired_times("first process", Path("/a"), Path("/b"), pairs=2, cold=True, timer=timer)
    caches = [cache for _, _, cache in calls]
    assert len(calls) == 4 and None not in caches and len(set(caches)) == 4
    assert times.ratios == (0.4, 4.0 / 12.0)


@pytest.mark.quick
def test_pairs_below_one_are_refused():
    with pytest.raises(ValueError, match="pairs must be >= 1, got 0"):
        tree_ratio.paired_times("x", Path("/a"), Path("/b"), pairs=0, timer=lambda *args: 1.0)


@pytest.mark.quick
@pytest.mark.parametrize("argv, message", [
    (["--sections", "cold-start", "--old-tree", "/no/such/tree"], "'/no/such/tree' is not a directory"),
    (["--sections", "skills", "--old-tree", "."], "--old-tree times the learners and cold-start sections"),
    (["--sections", "learners", "--old-tree", "/", "--old-tree-pairs", "0"], "--old-tree-pairs"),
])
def test_a_bad_old_tree_is_refused_before_any_measurement(argv, message, capsys):
    with pytest.raises(SystemExit) as exited:
        speed.main(argv)
    assert exited.value.code == 2 and message in capsys.readouterr().err


@pytest.mark.quick
def test_a_directory_without_the_run_command_is_not_a_tree(tmp_path):
    assert "has no benchmarks/run.py" in tree_ratio.tree_problem(tmp_path)
    assert tree_ratio.tree_problem(tree_ratio.this_tree()) is None  # this checkout has it


def _fake_tree(root: Path, exit_code: int) -> Path:
    """A tree whose run command records its arguments and exits ``exit_code``."""
    (root / "benchmarks").mkdir(parents=True)
    (root / "benchmarks" / "__init__.py").write_text("")
    (root / "benchmarks" / "run.py").write_text(
        "import os, sys\n"
        "open(os.path.join(os.path.dirname(__file__), 'argv.txt'), 'w').write(' '.join(sys.argv[1:]) + '\\n' + "
        "os.environ.get('NUMBA_CACHE_DIR', '-'))\n"
        f"print('last words'); sys.exit({exit_code})\n")
    return root


@pytest.mark.cli
def test_a_run_is_a_fresh_process_of_the_trees_own_command(tmp_path):
    tree = _fake_tree(tmp_path / "old", 0)
    seconds = tree_ratio.time_run(tree, tmp_path / "out", tmp_path / "numba")
    argv, cache = (tree / "benchmarks" / "argv.txt").read_text().splitlines()
    assert seconds > 0 and argv == f"--fresh --no-progress --out {tmp_path / 'out'}" and cache == str(tmp_path / "numba")


@pytest.mark.cli
def test_a_run_that_fails_in_a_tree_is_reported_with_its_last_lines(tmp_path):
    tree = _fake_tree(tmp_path / "old", 3)
    with pytest.raises(tree_ratio.TreeRunError, match=r"exited 3 in .*old:\nlast words"):
        tree_ratio.time_run(tree, tmp_path / "out")


@pytest.mark.quick
def test_a_child_started_elsewhere_imports_the_same_code(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PYTHONPATH", "." + tree_ratio.os.pathsep + "/abs/lib")
    environment = tree_ratio.child_environment(first=Path("/tree"), NUMBA_CACHE_DIR="/cache")
    assert environment["PYTHONPATH"].split(tree_ratio.os.pathsep) == ["/tree", str(tmp_path), "/abs/lib"]
    assert environment["NUMBA_CACHE_DIR"] == "/cache"
    monkeypatch.delenv("PYTHONPATH")
    assert "PYTHONPATH" not in tree_ratio.child_environment()


@pytest.mark.quick
def test_a_failed_run_in_either_tree_fails_the_section_and_names_it(monkeypatch, capsys):
    """A run that exits non-zero is a failed measurement (the command exits 1), not a missed goal."""
    from types import SimpleNamespace

    def failing(*args, **kwargs):
        raise tree_ratio.TreeRunError("`python -m benchmarks.run` exited 3 in /old")

    monkeypatch.setattr(tree_ratio, "paired_times", failing)
    args = SimpleNamespace(old_tree=Path("/old"), old_tree_pairs=1)
    result = speed._against_old_tree(args, "default run", False, tree_ratio.DEFAULT_RUN_RATIO_GOAL, "a third")
    assert result.failed and [goal.measured for goal in result.goals] == ["not measured"]
    assert "exited 3 in /old" in capsys.readouterr().out
