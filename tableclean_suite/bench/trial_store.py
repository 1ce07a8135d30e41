"""The fidelity trial store: one CSV of complete rounds, rewritten atomically after every round.

Reading is defensive: a damaged *last* line (a cut write) and incomplete rounds are dropped (and
logged); a damaged line elsewhere is a [`TrialStoreError`][tableclean_suite.bench.trial_store.TrialStoreError]
naming the line and the column.
"""

from __future__ import annotations

import csv
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
    """Stored trials that cannot be used: a damaged file, or trials of another run; the message names the file."""


def _parse(text: str, line: int, path: Path) -> dict:
    try:
        values = next(csv.reader([text]), [])  # a blank line: no values
    except csv.Error as error:
        raise TrialStoreError(f"{path}:{line}: not a CSV row ({error})") from None
    if len(values) != len(TRIAL_FIELDS):
        raise TrialStoreError(f"{path}:{line}: the row has {len(values)} of {len(TRIAL_FIELDS)} columns")
    parsed = dict(zip(TRIAL_FIELDS, values))
    for names, kind, what in ((INTEGER_FIELDS, int, "an integer"), (FLOAT_FIELDS, float, "a number")):
        for name in names:
            try:
                parsed[name] = kind(parsed[name])
            except ValueError:
                raise TrialStoreError(f"{path}:{line}: column {name!r} is {parsed[name]!r}, not {what}") from None
    return parsed


def read_lines(path: Path, error: type = TrialStoreError, hint: str = "use --fresh to start over") -> list[str]:
    """The lines of the UTF-8 text file ``path``, ``[]`` when it does not exist; ``error`` (default
    [`TrialStoreError`][tableclean_suite.bench.trial_store.TrialStoreError]) naming the file when unreadable."""
    if not Path(path).exists():
        return []
    try:
        return Path(path).read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError as cause:
        raise error(f"{path}: not a UTF-8 text file (byte {cause.start}: {cause.reason}); {hint}") from None
    except OSError as cause:
        raise error(f"{path}: cannot be read ({cause.strerror or cause})") from None


def read_rows(path: Path, log: Callable[[str], None] | None = None) -> list[dict]:
    """Every valid row of ``path`` (``[]`` when it does not exist); a damaged last line is dropped."""
    lines = read_lines(path)
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
            rows.append(_parse(text, number, path))
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
    """Write ``rows`` (of ``fieldnames``) to ``path`` as CSV atomically (the directory is created if missing)."""
    def write(temporary: Path) -> None:
        with temporary.open("w", newline="") as handle:
            writer = csv.DictWriter(handle, fieldnames=fieldnames)
            writer.writeheader()
            writer.writerows(rows)

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, write)
