"""The skills on every object type: skill success and fidelity per object x skill, alone and mixed.

    tableclean-bench objects [--objects milk,bottle,...] [--settings alone,mixed] [--mix-with box]
                             [--random N] [--episodes E] [--seed S] [--out DIR] [--plugins my_objects.py]

For every object type and setting, ``E`` episodes from uniform all-unclean starts, each executing
the model's shortest plan with the skills (Panda): ``alone`` on the ``paper``-shaped spec, ``mixed`` on
3 segments with ``--mix-with`` (``cylinder`` when that is the measured type; the ``partner`` column).
Per skill, *success* is the skill's own report, *fidelity* the share of executions whose observed
state is the model's prediction, each with its one-sided 95 % lower bound
([lower_bound][tableclean_suite.bench.fidelity.lower_bound]).  An episode stops at its first failed skill.
Writes ``DIR/object_table.csv`` (one row per object x setting x skill, rewritten after every cell).

``--random N`` measures ``N`` generated objects instead
([`random_objects`][tableclean_suite.environments.object_generator.random_objects] of ``--seed``), mixed
with the partner, in ``E`` (default 2) episodes each: a start with every object lying, a random history of
1 to `MAX_HISTORY` state-changing actions, then the shortest plan; each failure is classified by phase and
cause in ``DIR/object_failures.csv``.  The exit code is 1 when the scene refused every cell.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections import Counter
from pathlib import Path

from tableclean_suite.bench import cli, fidelity, trial_store
from tableclean_suite.bench.fidelity import CONFIDENCE, lower_bound, percent_down  # noqa: F401  (re-exported)

#: Settings: the object alone on the paper-shaped spec, or mixed with another type on three segments.
SETTINGS = ("alone", "mixed")
#: Segments of the mixed setting.
MIXED_SEGMENTS = 3
#: The partner of ``--mix-with``'s first type when that is the measured object itself.
FALLBACK_PARTNER = "cylinder"
#: Default output directory and file.
DEFAULT_OUT = "results/object_table"
TABLE_CSV = "object_table.csv"
#: Columns of the CSV, in order.
COLUMNS = ("object", "setting", "partner", "skill", "executions", "successes", "success_rate", "success_lower",
           "agreements", "fidelity", "fidelity_lower", "retries", "episodes", "episode_successes", "seconds")
#: Failures of ``--random``, one row each.
FAILURES_CSV = "object_failures.csv"
FAILURE_COLUMNS = ("object", "params", "episode", "start", "history", "skill", "phase", "cause", "retries", "reason")
#: Longest random history [actions] before the plan in a ``--random`` episode.
MAX_HISTORY = 6
#: Episodes per generated object unless ``--episodes`` says.
RANDOM_EPISODES = 2
#: The program name in messages unless the caller gives one.
PROG = "tableclean-bench objects"


def partner_for(kind: str, setting: str, partner: str) -> str:
    """The partner type actually used with ``kind`` in ``setting``: ``""`` alone, ``partner`` mixed unless it is
    ``kind`` itself (then `FALLBACK_PARTNER`)."""
    if setting == "alone":
        return ""
    return partner if partner != kind else FALLBACK_PARTNER


def spec_for(kind: str, setting: str, partner: str):
    """The task spec of one cell (uniform all-unclean starts); the partner is
    [`partner_for`][tableclean_suite.bench.object_table.partner_for]'s."""
    from tableclean_suite.task import TaskSpec

    if setting == "alone":
        return TaskSpec(f"objects_{kind}_alone", objects=(kind,), start="uniform_unclean")
    other = partner_for(kind, setting, partner)
    return TaskSpec(f"objects_{kind}_mixed", segments=MIXED_SEGMENTS, objects=(kind, other), start="uniform_unclean")


def _measure(kind: str, setting: str, partner: str, model, episodes: int, seed: int, plan_of=fidelity.shortest_plan,
             log=None) -> tuple[list[dict], dict]:
    """Rows (`COLUMNS`, one per skill) and the tally of ``episodes`` episodes of ``model`` executing ``plan_of``'s
    plans ([`play_episodes`][tableclean_suite.bench.fidelity.play_episodes])."""
    started = time.perf_counter()
    tally = fidelity.play_episodes(episodes, plan_of, model, log, f"{kind} {setting}", task=model.spec, seed=seed)
    return _rows(kind, setting, partner, tally["skills"], episodes, tally["successes"],
                 time.perf_counter() - started), tally


def _rows(kind: str, setting: str, partner: str, counts: dict, episodes: int, wins: int, seconds: float) -> list[dict]:
    return [{"object": kind, "setting": setting, "partner": partner, "skill": name, "executions": n,
             "successes": success, "success_rate": success / n, "success_lower": round(lower_bound(success, n), 4),
             "agreements": agree, "fidelity": agree / n, "fidelity_lower": round(lower_bound(agree, n), 4),
             "retries": retries, "episodes": episodes, "episode_successes": wins, "seconds": round(seconds, 1)}
            for name, (n, success, agree, retries) in counts.items()]


def failure_class(result) -> tuple[str, str]:
    """``(phase, cause)`` of a failed skill result: its last phase and its reason without the phase, numbers (not
    those in names such as ``S1``) as N; a motion that completed in a state other than the model's is one cause."""
    phase = result.final_phase or "-"
    reason = result.reason[len(phase) + 2:] if result.reason.startswith(phase + ": ") else result.reason
    if reason.startswith("ended in "):
        return phase, "ended in a state other than the model's successor"
    return phase, re.sub(r"(?<![A-Za-z])-?\d+(\.\d+)?", "N", reason)


def run_random(kind, index: int, episodes: int, seed: int, partner: str) -> tuple[list[dict], list[dict]]:
    """Rows (one per skill) and failures of ``episodes`` random episodes of generated object type ``kind``
    (the ``index``-th of ``seed``), mixed with ``partner``; episode ``e`` draws from
    ``SeedSequence([seed, index, e])``."""
    import numpy as np

    from tableclean_suite.task import TaskModel

    model = TaskModel(spec=spec_for(kind.name, "mixed", partner))
    starts = [s for s in model.reachable_states() if not s.is_terminal and not s.holding]
    drawn = []  # the start of each episode

    def plan_of(env, model, episode):
        rng = np.random.default_rng(np.random.SeedSequence([seed, index, episode]))
        state = start = starts[rng.integers(len(starts))]
        drawn.append(start)
        env.rng = np.random.default_rng(int(rng.integers(2 ** 32)))
        env.set_start_state(start)
        env.reset()
        history = []
        for _ in range(int(rng.integers(1, MAX_HISTORY + 1))):
            if state.is_terminal:
                break
            moves = [a for a in range(model.n_actions) if model.step(state, a)[0] != state]
            history.append(moves[rng.integers(len(moves))])
            state = model.step(state, history[-1])[0]
        return history + model.shortest_plan(state)

    rows, tally = _measure(kind.name, "random", partner, model, episodes, seed, plan_of)
    failures = []
    for episode, _, results in tally["failures"]:
        if results and not results[-1].success:
            result, history = results[-1], " ".join(model.action_name(r.action) for r in results[:-1])
            phase, cause = failure_class(result)
            failures.append({"object": kind.name, "params": kind.description, "episode": episode, "history": history,
                             "start": drawn[episode].name, "skill": model.action_name(result.action), "phase": phase,
                             "cause": cause, "retries": result.retries, "reason": result.reason})
    return rows, failures


def markdown(rows: list[dict]) -> str:
    """One line per object x setting: its successful episodes, and per skill ``successes/executions, fid
    agreements/executions: >= `` the success's and the fidelity's one-sided 95 % lower bounds (rounded down)."""
    skills = list(dict.fromkeys(row["skill"] for row in rows))
    cells: dict[tuple, dict] = {}
    for row in rows:
        cells.setdefault((row["object"], row["setting"]), {})[row["skill"]] = row
    lines = []
    for (kind, setting), by_skill in cells.items():
        first = next(iter(by_skill.values()))
        entries = []
        for row in (by_skill.get(skill) for skill in skills):
            n, success, agree = (0, 0, 0) if row is None else map(int, (row["executions"], row["successes"],
                                                                          row["agreements"]))
            entries.append("-" if row is None else f"{success}/{n}, fid {agree}/{n}: >= "
                           f"{percent_down(lower_bound(success, n))} / {percent_down(lower_bound(agree, n))}")
        lines.append((kind, setting, first.get("partner") or "-",
                      f"{first['episode_successes']}/{first['episodes']}", *entries))
    return cli.markdown_table(lines, ("object", "setting", "partner", "successful episodes", *skills))


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The command line: the shared options of [`cli`][tableclean_suite.bench.cli] and the table's own."""
    parser = cli.command_parser(prog, __doc__.split("\n\n")[0])
    parser.add_argument("--objects", type=cli.name_list, default=None, metavar="TYPE,...",
                        help="comma-separated registered object types (default every registered type: the "
                             "catalog and those your --plugins register)")
    parser.add_argument("--settings", type=cli.name_list, default=SETTINGS, metavar="SETTING,...",
                        help=f"comma-separated settings among {', '.join(SETTINGS)} (default both)")
    parser.add_argument("--mix-with", default="box", metavar="TYPE",
                        help=f"the other object type of the mixed setting (default box); when it is the measured "
                             f"type itself, {FALLBACK_PARTNER} is used instead (the partner column of the table and "
                             "CSV names the partner actually used)")
    parser.add_argument("--episodes", type=cli.positive_int, default=None,
                        help=f"optimal-plan episodes per object x setting (default 30); with --random, random episodes "
                             f"per generated object (default {RANDOM_EPISODES})")
    parser.add_argument("--random", type=cli.non_negative_int, default=0, metavar="N",
                        help="measure N generated objects (seeded by --seed) from random reachable starts and random "
                             "histories; the catalog is then measured only if --objects names types")
    cli.add_seed_argument(parser, "the placements and layouts")
    cli.add_out_argument(parser, cli.DIRECTORY, DEFAULT_OUT, f"directory of {TABLE_CSV}")
    parser.add_argument("--quiet", action="store_true", help="print only the table")
    return parser


def random_table(args, rows: list[dict], table: Path, started: float, log=print) -> tuple[list[dict], int, int]:
    """Measure ``args.random`` generated objects: their rows appended to ``rows`` and written to ``table``,
    failures to `FAILURES_CSV`; returns the ``random objects`` rows, the measured and the refused objects."""
    from tableclean_suite.environments.object_generator import random_objects
    from tableclean_suite.environments.objects import register_object

    episodes = args.episodes or RANDOM_EPISODES
    failures, totals, measured, refused, wins = [], {}, 0, 0, 0
    kinds = random_objects(args.random, args.seed)
    for index, kind in enumerate(kinds):
        register_object(kind, overwrite=True)
        try:
            cell, lost = run_random(kind, index, episodes, args.seed, args.mix_with)
        except ValueError as error:  # refused by the scene: a finding, not a crash
            refused += 1
            print(f"[{index + 1}/{len(kinds)}] {kind.name} ({kind.description}): refused: {error}")
            continue
        measured += 1
        rows += cell
        failures += lost
        done = cell[0]["episode_successes"] if cell else 0
        wins += done
        for row in cell:
            counts = ("executions", "successes", "agreements", "retries")
            totals[row["skill"]] = [total + row[key] for total, key in zip(totals.get(row["skill"], [0] * 4), counts)]
        trial_store.write_rows(table, rows, COLUMNS)
        trial_store.write_rows(table.parent / FAILURES_CSV, failures, FAILURE_COLUMNS)
        log(f"[{index + 1}/{len(kinds)}] {kind.name} ({kind.description}): {done}/{episodes} episodes, "
            f"{sum(r['executions'] for r in cell)} skills, {sum(r['retries'] for r in cell)} retries, "
            f"{len(lost)} failed"
            + "".join(f"; {f['skill']} {f['phase']}: {f['cause']}" for f in lost)
            + f" ({time.perf_counter() - started:.0f} s)")
    total = _rows(f"random objects ({measured})", "random", args.mix_with, totals, episodes * measured, wins,
                  time.perf_counter() - started)
    trial_store.write_rows(table.parent / FAILURES_CSV, failures, FAILURE_COLUMNS)
    classes = Counter((f["skill"], f["phase"], f["cause"]) for f in failures)
    print()
    counted = [(*key, n) for key, n in classes.most_common()] or [("-", "-", "no failure", 0)]
    print(cli.markdown_table(counted, ("skill", "phase", "cause", "failures")))
    return total, measured, refused


def main(argv: list[str] | None = None, prog: str | None = None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit code: 1 when every cell was
    refused, else 0."""
    parser, args = cli.parse_command(build_parser, argv, prog or PROG)
    from tableclean_suite.environments.objects import object_type_names
    from tableclean_suite.task import TaskModel

    known = object_type_names()
    objects = args.objects or (() if args.random else tuple(known))
    for name in (*objects, args.mix_with):
        if name not in known:
            parser.error(f"unknown object type {name!r}; registered: {', '.join(known)} (add yours with --plugins)")
    bad = [s for s in args.settings if s not in SETTINGS]
    if bad:
        parser.error(f"--settings: unknown {bad[0]!r}; allowed: {', '.join(SETTINGS)}")
    log = None if args.quiet else (lambda line: print(line, flush=True))
    rows: list[dict] = []
    table = Path(args.out) / TABLE_CSV
    started = time.perf_counter()
    cells = refused = 0
    for kind in objects:
        for setting in args.settings:
            used = partner_for(kind, setting, args.mix_with)
            if used and used != args.mix_with:
                print(f"{kind} {setting}: partner {used} (--mix-with {args.mix_with} is the measured type itself)")
            cells += 1
            try:
                model = TaskModel(spec=spec_for(kind, setting, args.mix_with))
                rows += _measure(kind, setting, used, model, args.episodes or 30, args.seed, log=log)[0]
            except ValueError as error:  # refused by the scene (cannot be held, does not fit): a finding, not a crash
                refused += 1
                print(f"{kind} {setting}: refused: {error}")
                continue
            trial_store.write_rows(table, rows, COLUMNS)
            if log:
                log(f"{kind} x {setting} done ({time.perf_counter() - started:.0f} s)")
    shown = list(rows)
    if args.random:
        total, measured, lost = random_table(args, rows, table, started, log or (lambda line: None))
        rows, shown = rows + total, shown + total
        cells, refused = cells + measured + lost, refused + lost
    trial_store.write_rows(table, rows, COLUMNS)  # also when every cell was refused: the file the report names exists
    print(markdown(shown))
    print(f"\n{table} ({time.perf_counter() - started:.0f} s); per skill: successes/executions, fid "
          f"agreements/executions: >= the one-sided {CONFIDENCE:.0%} lower bounds of success / fidelity")
    return 1 if cells and refused == cells else 0


if __name__ == "__main__":
    from tableclean_suite.bench.commands import run_alias

    sys.exit(run_alias("objects", "python -m tableclean_suite.bench.object_table"))
