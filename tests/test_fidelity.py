"""Fidelity tables and calibration: aggregation on hand-made trials, resume checks, a tiny calibration in MuJoCo."""

import json

import pytest

from tableclean_suite.bench import calibrate, fidelity
from tableclean_suite.bench.fidelity import FAULT, pair_table, skill_table, summary
from tableclean_suite.bench.trial_store import TrialStoreError, read_rows
from tableclean_suite.bench.trial_store import TRIAL_FIELDS
from tableclean_suite.learners import TransitionTable, train
from tableclean_suite.task import Action, Outcome, TaskModel

MODEL = TaskModel()


def row(state, action, observed=None, outcome=None, success=1, steps=20, round_index=0):
    expected, expected_outcome = MODEL.step(state, action)
    observed = expected.index if observed is None else observed
    outcome = expected_outcome.name.lower() if outcome is None else outcome
    return {
        "round": round_index, "seed": fidelity.round_seed(0, round_index), "layout": "1-1", "reached_by": "plan",
        "state": state, "action": action.name.lower(), "expected_state": expected.index,
        "expected_outcome": expected_outcome.name.lower(), "observed_state": observed, "observed_outcome": outcome,
        "agree": int(observed == expected.index and outcome == expected_outcome.name.lower()),
        "success": success, "improper": int(expected_outcome == Outcome.IMPROPER), "steps": steps,
        "retries": 0, "wall_time": 0.5, "env_time": 0.4, "reason": "ok",
    }


ROWS = [
    row(0, Action.MOVE), row(0, Action.MOVE, observed=0, outcome="ineffective", success=0, round_index=1),
    row(0, Action.CLEAN, steps=0),  # improper: refused
    row(1, Action.CLEAN, steps=400), row(1, Action.CLEAN, observed=-1, outcome=FAULT, success=0, round_index=1),
]


def test_pair_and_skill_tables():
    pairs = {(p["state"], p["action"]): p for p in pair_table(ROWS)}
    assert pairs[(0, "move")]["trials"] == 2 and pairs[(0, "move")]["agreement_rate"] == 0.5
    assert pairs[(0, "move")]["disagreements_seen"] == "0/ineffective"
    assert pairs[(1, "clean")]["faults"] == 1
    skills = {s["skill"]: s for s in skill_table(ROWS)}
    assert skills["move"]["executions"] == 2 and skills["move"]["success_rate"] == 0.5
    assert skills["clean"]["executions"] == 2 and skills["clean"]["refused"] == 1  # the improper clean did not run
    assert skills["clean"]["mean_steps"] == pytest.approx(210.0)
    result = summary(ROWS)
    assert result["agreement"] == pytest.approx(3 / 5) and result["faults"] == 1 and result["rounds"] == 2
    assert result["agreements"] == 3 and result["successes"] == {"move": 1, "pick": 0, "place": 0, "clean": 1}


def test_the_summary_prints_counts_rates_and_exact_lower_bounds():
    from scipy.stats import beta

    # one-sided 95 % Clopper-Pearson lower bound of k of n: the 5 % quantile of Beta(k, n - k + 1)
    assert fidelity.lower_bound(3, 5) == pytest.approx(beta.ppf(0.05, 3, 3))  # 0.1893
    assert fidelity.lower_bound(1, 2) == pytest.approx(1 - 0.95 ** 0.5)  # 0.0253
    lines = fidelity.summary_lines(summary(ROWS), "paper on Panda")
    assert lines == [
        "paper on Panda: 5 trials in 2 round(s): agreement 3/5 = 60.00 % (95 % lower bound 18.9 %), "
        "lowest pair 50.00 %, 1 abstraction fault(s)",
        "  move: success 1/2 = 50.00 % (95 % lower bound 2.5 %)",  # pick and place never ran: not listed
        "  clean: success 1/2 = 50.00 % (95 % lower bound 2.5 %)",
    ]


def test_calibrated_table_counts_observations_and_leaves_faults_out(tmp_path):
    table = calibrate.calibrated_table(ROWS)
    assert sorted(table.successors(0, Action.MOVE)) == [(0, int(Outcome.INEFFECTIVE), 0.5), (1, int(Outcome.ROUTINE), 0.5)]
    assert table.counts[1, Action.CLEAN] == 1  # the fault is not a transition
    assert "1 abstraction faults excluded" in table.source
    assert table.successors(5, Action.MOVE) == [(4, int(Outcome.ROUTINE), 1.0)]  # unmeasured: the model's
    path = tmp_path / "t.json"
    table.to_json(path)
    loaded = TransitionTable.from_json(path)
    assert loaded.successors(0, Action.MOVE) == table.successors(0, Action.MOVE)


def _record(trials_csv, model=MODEL, physics_options=None):
    """The configuration record fidelity writes beside its trials."""
    fidelity.configuration_path(trials_csv).write_text(
        json.dumps(fidelity.run_configuration(model, physics_options)))


def test_trials_file_checks(tmp_path):
    bad = tmp_path / "trials.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(TrialStoreError, match="unexpected columns"):
        read_rows(bad)
    good = tmp_path / "good.csv"
    per_round = fidelity.trials_per_round(TaskModel(), [a.rule_name for a in Action])
    fidelity.write_csv(good, ROWS[:1] * per_round)  # one complete round (as far as counts go)
    assert read_rows(good)[0]["state"] == 0 and list(read_rows(good)[0]) == list(TRIAL_FIELDS)
    with pytest.raises(TrialStoreError, match="options they were measured with .* are unknown"):
        fidelity.collect(1, seed=5, trials_csv=good, log=None)  # no configuration beside the trials
    _record(good)
    with pytest.raises(TrialStoreError, match="another --seed"):
        fidelity.collect(1, seed=5, trials_csv=good, log=None)


def test_a_truncated_last_line_and_a_partial_round_are_dropped_not_reported(tmp_path):
    """An interrupted write: the damaged line goes, the incomplete round runs again, nothing crashes."""
    from tableclean_suite.bench import trial_store

    path = tmp_path / "trials.csv"
    pairs = [(s.index, a) for s in MODEL.reachable_states() if not s.is_terminal for a in Action]
    complete = [row(s, a, round_index=0) for s, a in pairs]
    partial = [row(s, a, round_index=1) for s, a in pairs[:62]]
    trial_store.write_rows(path, complete + partial)
    text = path.read_text()
    path.write_text(text + "2,7,1-1,plan,0,mo")  # a row cut off mid-write
    messages = []
    rows = read_rows(path, messages.append)
    assert len(rows) == 72 + 62 and "damaged last line" in messages[0]
    kept = trial_store.complete_rounds(rows, 72, messages.append)
    assert {row["round"] for row in kept} == {0} and "rounds [1] are incomplete" in messages[1]
    _record(path)
    calibrate.main(["--from-trials", str(path), "--out", str(tmp_path / "t.json"), "--quiet"])  # no TypeError
    assert TransitionTable.from_json(tmp_path / "t.json").counts.sum() == 72


def test_a_damaged_line_before_the_end_is_an_error_naming_it(tmp_path):
    from tableclean_suite.bench import trial_store

    path = tmp_path / "trials.csv"
    trial_store.write_rows(path, [ROWS[0]] * 3)
    lines = path.read_text().splitlines()
    lines[2] = lines[2].replace(",0,", ",zero,", 1)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(TrialStoreError, match=r"trials.csv:3: column .* is 'zero', not an integer"):
        read_rows(path)


@pytest.mark.parametrize("argv", [["--trials", "0"], ["--seed", "-1"], ["--actions", "wipe"]])
def test_fidelity_cli_rejects_bad_arguments(argv, capsys):
    with pytest.raises(SystemExit) as exit_info:
        fidelity.main(argv)
    assert exit_info.value.code == 2
    assert "error" in capsys.readouterr().err


def test_calibrate_cli_rejects_bad_arguments(tmp_path, capsys):
    for argv in (["--out", str(tmp_path / "t.txt")], ["--from-trials", str(tmp_path / "missing.csv")]):
        with pytest.raises(SystemExit) as exit_info:
            calibrate.main(argv)
        assert exit_info.value.code == 2


@pytest.mark.slow
def test_tiny_calibration_trains_the_calibrated_backend(tmp_path, capsys):
    out = tmp_path / "transitions.json"
    # one round of the fast skills (clean left out: its pairs keep the model's successor)
    assert calibrate.main(["--trials", "1", "--actions", "move,pick,place", "--out", str(out), "--quiet"]) == 0
    document = json.loads(out.read_text())
    assert document["format"] == "tableclean_suite.transition_table"
    table = TransitionTable.from_json(out)
    measured = table.counts.sum()
    assert measured == 18 * 3  # every reachable non-terminal state x move/pick/place, once
    assert table.counts[:, Action.CLEAN].sum() == 0
    trials = read_rows(out.with_suffix(".trials.csv"))
    assert {r["reached_by"] for r in trials} <= {"plan", "staged"} and len(trials) == 54
    # agreement in physics: every measured successor is the model's (reported, and checked loosely)
    agree = sum(r["agree"] for r in trials) / len(trials)
    assert agree >= 0.9, f"physics agreed with the model on only {agree:.0%} of move/pick/place trials"
    result = train("q_learning", "r4", runs=4, iterations=300, backend="calibrated", transitions=str(out))
    assert result.rewards.shape == (4, 300) and "physics calibration" in result.config["transitions"]
    # resuming: the round is already measured, so no physics runs and the same table comes out
    assert calibrate.main(["--trials", "1", "--actions", "move,pick,place", "--out", str(out), "--quiet"]) == 0
    assert TransitionTable.from_json(out).counts.sum() == measured


def test_fidelity_and_calibrate_cli_reject_bad_tasks_and_actions(capsys):
    for argv in (["--task", "nope"], ["--task", "three_segments", "--actions", "move_back"]):
        with pytest.raises(SystemExit) as exit_info:
            fidelity.main(argv)
        assert exit_info.value.code == 2
        assert "error: --" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:
        calibrate.main(["--task", "nope", "--out", "x.json"])
    assert exit_info.value.code == 2 and "unknown task spec 'nope'" in capsys.readouterr().err


def test_tables_use_the_specs_action_names_and_state_names():
    model = TaskModel(spec="three_segments_two_objects")
    start = model.start_state
    rows = [{
        "round": 0, "seed": 0, "layout": "1.1-1", "reached_by": "plan", "state": start.index, "action": "pick",
        "expected_state": model.step(start, "pick")[0].index, "expected_outcome": "routine",
        "observed_state": model.step(start, "pick")[0].index, "observed_outcome": "routine", "agree": 1,
        "success": 1, "improper": 0, "steps": 20, "retries": 0, "wall_time": 0.1, "env_time": 0.1, "reason": "ok"}]
    (pair,) = fidelity.pair_table(rows, model)
    assert pair["state_name"] == start.name and "o1" in pair["state_name"]
    skills = {s["skill"]: s for s in skill_table(rows, model)}
    assert skills["pick"]["executions"] == 1 and skills["clean"]["executions"] == 0
    counts, faults = calibrate.count_transitions(rows, model)
    assert counts == {(start.index, model.action_index("pick")): {(rows[0]["observed_state"], int(Outcome.ROUTINE)): 1}}


@pytest.mark.slow
def test_rounds_on_two_workers_equal_the_serial_rounds(tmp_path):
    """Rounds are independent tasks: two processes give the same trials as one (timings aside)."""
    from tableclean_suite.executors import LocalExecutor

    def essentials(rows):
        return [{k: v for k, v in row.items() if k not in ("wall_time", "env_time")} for row in rows]

    kwargs = dict(trials=2, seed=3, log=None, actions=("move", "pick"))
    serial = fidelity.collect(trials_csv=tmp_path / "serial.csv", **kwargs)
    with LocalExecutor(workers=2) as executor:
        parallel = fidelity.collect(trials_csv=tmp_path / "parallel.csv", executor=executor, **kwargs)
    assert len(serial) == 2 * 18 * 2 and essentials(parallel) == essentials(serial)
    assert essentials(read_rows(tmp_path / "parallel.csv")) == essentials(serial)


@pytest.mark.slow
def test_small_fidelity_sweep_on_three_segments_two_objects(tmp_path):
    model = TaskModel(spec="three_segments_two_objects")
    rows = fidelity.collect(1, seed=1, trials_csv=tmp_path / "trials.csv", log=None, actions=("pick", "place"),
                            model=model)
    non_terminal = [s for s in model.reachable_states() if not s.is_terminal]
    assert len(rows) == 2 * len(non_terminal)
    result = summary(rows, model)
    ran = {skill: n for skill, (rate, n) in result["skills"].items() if n}
    assert set(ran) == {"pick", "place"} and min(ran.values()) >= 50
    assert result["agreement"] >= 0.97, f"agreement {result['agreement']:.2%}"


def test_stored_trials_of_another_robot_or_randomisation_are_not_resumed(tmp_path):
    """The trials CSV records the spec and scene options it was measured with; resuming it under
    other options is refused before any scene is built, and --fresh starts over."""
    from tableclean_suite.bench import trial_store

    path = tmp_path / fidelity.TRIALS_CSV
    trial_store.write_rows(path, [])
    panda = {"env_kwargs": {"robots": "Panda"}}
    fidelity.check_configuration(path, fidelity.run_configuration(TaskModel(), panda))
    record = path.with_name("fidelity_trials" + fidelity.CONFIGURATION_SUFFIX)
    assert json.loads(record.read_text())["physics_options"] == panda
    fidelity.check_configuration(path, fidelity.run_configuration(TaskModel(), panda))  # same: resumes
    for options in ({"env_kwargs": {"robots": "Sawyer"}}, {"env_kwargs": {"robots": "Panda", "randomization": "on"}}):
        with pytest.raises(TrialStoreError, match="measured with another physics_options"):
            fidelity.collect(1, 0, path, log=None, physics_options=options)
    with pytest.raises(TrialStoreError, match="another task"):
        fidelity.collect(1, 0, path, log=None, physics_options=panda,
                         model=TaskModel(spec="three_segments_two_objects"))


def test_trials_without_a_configuration_record_are_refused_and_an_empty_file_is_adopted(tmp_path):
    from tableclean_suite.bench import trial_store

    path = tmp_path / fidelity.TRIALS_CSV
    trial_store.write_rows(path, [ROWS[0]] * 3)  # e.g. its config.json was deleted
    with pytest.raises(TrialStoreError, match="fidelity_trials.config.json is missing"):
        fidelity.check_configuration(path, fidelity.run_configuration(TaskModel(), None))
    assert not fidelity.configuration_path(path).exists()
    trial_store.write_rows(path, [])  # a header only: nothing to mix up
    fidelity.check_configuration(path, fidelity.run_configuration(TaskModel(), None))
    assert fidelity.configuration_path(path).exists()


def test_trials_measured_with_other_plugin_code_are_not_resumed(tmp_path):
    """The configuration record keys on the --plugins sources: an edited skill or object type
    measures other trials, so resuming them is refused (the record without plugins is as before)."""
    from tableclean_suite.bench import trial_store

    plugin = tmp_path / "fidelity_plugin_extras.py"
    plugin.write_text("GRIP_FORCE = 10\n")
    path = tmp_path / fidelity.TRIALS_CSV
    trial_store.write_rows(path, [])
    fidelity.check_configuration(path, fidelity.run_configuration(TaskModel(), None, plugins=(str(plugin),)))
    assert "code_digest" in json.loads(fidelity.configuration_path(path).read_text())
    fidelity.collect(0, 0, path, log=None, plugins=(str(plugin),))  # the same code: resumes
    plugin.write_text("GRIP_FORCE = 11\n")
    with pytest.raises(TrialStoreError, match="another code_digest"):
        fidelity.collect(0, 0, path, log=None, plugins=(str(plugin),))
    assert fidelity.run_configuration(TaskModel(), None) != fidelity.run_configuration(TaskModel(), None, plugins=(str(plugin),))
