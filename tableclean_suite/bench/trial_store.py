"""The fidelity trial store: one CSV of complete rounds, rewritten atomically after every round.

A round is complete when it holds one trial per (reachable non-terminal state, executed action)
pair.  The file only ever grows by whole rounds (written under a temporary name and renamed), so
an interrupted run leaves the rounds it finished.  Reading is defensive anyway, for files from
older versions or copied by hand:

- a damaged *last* line (a write cut short) is dropped, and so is every incomplete round, with a
  message saying which rounds will be run again;
- a damaged line anywhere else is a `TrialStoreError` naming the line and the column;
- rows are never guessed: a round with the wrong number of trials is never reported as a result.
"""

from __future__ import annotations

import csv
import io
from collections import Counter
from pathlib import Path
from typing import Callable, Iterable

from tableclean_suite.bench.outputs import atomic_write

#: Columns of the trials CSV, in order.
TRIAL_FIELDS = (
    "round", "seed", "layout", "reached_by", "state", "action", "expected_state", "expected_outcome",
    "observed_state", "observed_outcome", "agree", "success", "improper", "steps", "retries", "wall_time", "env_time",
    "reason",
)
INTEGER_FIELDS = ("round", "seed", "state", "expected_state", "observed_state", "agree", "success", "improper", "steps",
                  "retries")
FLOAT_FIELDS = ("wall_time", "env_time")


class TrialStoreError(ValueError):
    """A trials file that cannot be used as it is; the message names the file, line and problem."""


def _parse(row: dict, line: int, path: Path) -> dict:
    if None in row or any(row.get(name) is None for name in TRIAL_FIELDS):
        raise TrialStoreError(f"{path}:{line}: the row has {len([v for v in row.values() if v is not None])} of "
                              f"{len(TRIAL_FIELDS)} columns")
    parsed = dict(row)
    for name in INTEGER_FIELDS:
        try:
            parsed[name] = int(row[name])
        except ValueError:
            raise TrialStoreError(f"{path}:{line}: column {name!r} is {row[name]!r}, not an integer") from None
    for name in FLOAT_FIELDS:
        try:
            parsed[name] = float(row[name])
        except ValueError:
            raise TrialStoreError(f"{path}:{line}: column {name!r} is {row[name]!r}, not a number") from None
    return parsed


def read_rows(path: Path, log: Callable[[str], None] | None = None) -> list[dict]:
    """Every valid row of ``path`` (``[]`` when it does not exist); a damaged last line is dropped."""
    path = Path(path)
    if not path.exists():
        return []
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as error:
        raise TrialStoreError(f"{path}: not a UTF-8 text file (byte {error.start}: {error.reason}); use --fresh to "
                              "start over") from None
    except OSError as error:
        raise TrialStoreError(f"{path}: cannot be read ({error.strerror or error})") from None
    if not lines:
        return []
    try:
        header = next(csv.reader([lines[0]]))
    except csv.Error as error:
        raise TrialStoreError(f"{path}:1: not a CSV header ({error}); use --fresh to start over") from None
    if tuple(header) != TRIAL_FIELDS:
        raise TrialStoreError(f"{path}: unexpected columns {header}; use --fresh to start over")
    rows = []
    for number, text in enumerate(lines[1:], start=2):
        try:
            row = next(csv.DictReader(io.StringIO(text), fieldnames=TRIAL_FIELDS))
            rows.append(_parse(row, number, path))
        except csv.Error as error:
            damaged = TrialStoreError(f"{path}:{number}: not a CSV row ({error})")
            if number != len(lines):
                raise damaged from None
            if log:
                log(f"dropping the damaged last line of {path} (an interrupted write): {damaged}")
        except TrialStoreError as error:
            if number != len(lines):
                raise
            if log:
                log(f"dropping the damaged last line of {path} (an interrupted write): {error}")
    return rows


def complete_rounds(rows: list[dict], per_round: int, log: Callable[[str], None] | None = None) -> list[dict]:
    """The rows of rounds with exactly ``per_round`` trials; incomplete rounds are dropped (and logged)."""
    counts = Counter(row["round"] for row in rows)
    partial = sorted(r for r, n in counts.items() if n != per_round)
    if partial and log:
        log(f"rounds {partial} are incomplete (trials {[counts[r] for r in partial]} of {per_round}); they run again")
    return [row for row in rows if counts[row["round"]] == per_round]


def write_rows(path: Path, rows: Iterable[dict], fieldnames: tuple[str, ...] = TRIAL_FIELDS) -> None:
    """Write ``rows`` (whole rounds; or any rows of ``fieldnames``) to ``path`` as CSV atomically: a
    temporary file, then a rename (the directory is created if missing)."""
    def write(temporary: Path) -> None:
        with temporary.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=fieldnames)
            writer.writeheader()
            writer.writerows(rows)

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, write)
