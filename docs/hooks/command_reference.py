"""MkDocs hook: the command reference, rendered from the command parsers themselves so it cannot drift.

``docs/commands.md`` holds the marker :data:`MARKER`; this hook replaces it with one section per command
of ``tableclean_suite.bench.commands.command_parsers()``: the command's ``--help`` as argparse prints
it (at a fixed width of :data:`HELP_WIDTH` columns, so the page does not depend on the terminal).
"""

from __future__ import annotations

import os
from contextlib import contextmanager

MARKER = "<!-- commands: generated from the parsers -->"
PAGE = "commands.md"
HELP_WIDTH = 100  # columns argparse wraps the help at
COMMANDS_MODULE = "tableclean_suite.bench.commands"


@contextmanager
def _columns(width: int):
    """Make argparse (which reads ``COLUMNS``) wrap at ``width`` columns for the duration."""
    previous = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        yield
    finally:
        if previous is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = previous


def command_helps() -> dict[str, str]:
    """Command name -> its parser's full help text, in the registry's order."""
    import importlib

    commands = importlib.import_module(COMMANDS_MODULE)
    with _columns(HELP_WIDTH):
        return {name: parser.format_help().rstrip() for name, parser in commands.command_parsers().items()}


def reference_markdown(helps: dict[str, str]) -> str:
    """One section per command: a heading naming the invocation and the help in a ``text`` block."""
    sections = []
    for name, text in helps.items():
        sections.append(f"## `tableclean-bench {name}`\n\n```text\n{text}\n```\n")
    return "\n".join(sections)


def on_page_markdown(markdown, page, config, files):
    """Replace the marker on the command reference page with the rendered help of every command."""
    if page.file.src_uri != PAGE:
        return markdown
    if MARKER not in markdown:
        raise ValueError(f"{PAGE} lost its marker {MARKER!r}; the command reference would not be generated")
    return markdown.replace(MARKER, reference_markdown(command_helps()))
