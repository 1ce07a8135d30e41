"""The repository speaks of the product: its README, docs, package, benchmarks and examples name no
issue number, no commit, no working session and no path on the machine that wrote them."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: What is scanned: files, and folders scanned whole (every text file below them).
SCANNED = ("README.md", "docs", "tableclean_suite", "benchmarks", "examples")
#: Folders below those that hold what tools write, not what people write.
SKIPPED_FOLDERS = {"__pycache__", ".ipynb_checkpoints"}
#: What must not appear, and why, as regular expressions over one line.
FORBIDDEN = {
    "an issue number": re.compile(r"\bissues?\s+#?\d+", re.IGNORECASE),
    # 7 to 40 hexadecimal digits with at least one letter and one digit, standing alone (not part of a
    # longer word or number, not a colour after '#'): how a commit is named in prose.
    "a commit hash": re.compile(r"(?<![#\w])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}(?!\w)"),
    "the word session": re.compile(r"\bsessions?\b", re.IGNORECASE),
    "a path on the writer's machine": re.compile(r"(?<![\w.~/])/(?:tmp|work)\b"),
}


def scanned_files() -> list:
    """Every text file of :data:`SCANNED` (a file with a NUL byte or that is not UTF-8 is binary)."""
    files = []
    for name in SCANNED:
        path = ROOT / name
        candidates = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
        for candidate in candidates:
            if SKIPPED_FOLDERS & set(candidate.relative_to(ROOT).parts):
                continue
            data = candidate.read_bytes()
            if b"\0" in data:
                continue
            try:
                files.append((candidate, data.decode("utf-8")))
            except UnicodeDecodeError:
                continue
    return files


def findings(text: str) -> list:
    """``(line number, what, match)`` of every forbidden pattern in ``text``."""
    return [(number, what, match.group(0)) for number, line in enumerate(text.splitlines(), 1)
            for what, pattern in FORBIDDEN.items() for match in pattern.finditer(line)]


@pytest.mark.parametrize("text, what", [
    ("as issue 16 asked", "an issue number"), ("see Issues #4", "an issue number"),
    ("measured at commit f690eb5", "a commit hash"), ("tree 0123456789abcdef0123456789abcdef01234567", "a commit hash"),
    ("in the previous session", "the word session"), ("Session notes", "the word session"),
    ("--old-tree /tmp/base", "a path on the writer's machine"), ("cd /work/main", "a path on the writer's machine"),
])
def test_each_pattern_finds_what_it_forbids(text, what):
    assert [found[1] for found in findings(text)] == [what]


@pytest.mark.parametrize("text", [
    "an issue with the grasp", "1234567 updates", "a decade of facades", "colour #1f77b4ff", "0x7fffffff",
    "sha256 of the file, e.g. `hashlib.sha256(data).hexdigest()`", "process_session(spec)",
    "https://example.org/work/item", "~/tmp/notes", "start_new_session=True",
])
def test_legitimate_text_passes(text):
    assert findings(text) == []


def test_the_repository_names_no_issue_commit_session_or_machine_path():
    found = [f"{path.relative_to(ROOT)}:{number}: {what}: {match!r}"
             for path, text in scanned_files() for number, what, match in findings(text)]
    assert not found, "\n".join(found)
