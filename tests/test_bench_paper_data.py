"""The paper's numbers ship as package data, and nothing points outside the repository."""

import re
from pathlib import Path

from tableclean_suite.bench import paper_data, tables

ROOT = Path(__file__).resolve().parents[1]
#: A relative path that climbs out of its folder (two dots, a slash, a name), in code or docstrings.
_CLIMBING_PATH = re.compile(r"\.\./[\w.-]")


def test_reference_is_a_plain_citation():
    assert paper_data.PAPER_REFERENCE.startswith("Accelerated Task Learning Using Q-learning")
    assert "Tables 3-4" in paper_data.PAPER_REFERENCE and "/" not in paper_data.PAPER_REFERENCE


def test_tables_use_the_packaged_paper_data():
    assert tables.PAPER_TABLE3 is paper_data.PAPER_TABLE3 and tables.PAPER_TABLE4 is paper_data.PAPER_TABLE4
    numbers = [c for c in tables.TABLE4_COLUMNS[:-1] if not c.endswith((tables.LOW, tables.HIGH))]
    paper = list(paper_data.PAPER_TABLE4_COLUMNS)
    assert numbers[:len(paper)] == paper  # the paper's columns first, in its order; ours after them
    quoted = tables.PAPER_TABLE4
    assert list(quoted.columns)[:len(paper)] == paper and len(quoted) > 0


def test_no_code_or_test_refers_to_files_outside_the_repository():
    sources = [*(ROOT / "tableclean_suite").rglob("*.py"), *(ROOT / "benchmarks").rglob("*.py"),
               *(ROOT / "tests").rglob("*.py"), ROOT / "setup.py"]
    assert len(sources) > 20
    offenders = [f"{path.relative_to(ROOT)}:{number}" for path in sources
                 for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
                 if _CLIMBING_PATH.search(line)]
    assert offenders == []
