"""Files written whole or not at all: [`atomic_write`][tableclean_suite.atomic_files.atomic_write]
writes a temporary beside the target and renames it over, so a reader sees the old file or the
complete new one, never a part.  Every file-system failure surfaces as
[`OutputError`][tableclean_suite.atomic_files.OutputError], one line naming the path and the reason.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Callable


class OutputError(OSError):
    """An output folder or file that cannot be used or written; the message names it and why."""


def describe_os_error(error: OSError) -> str:
    """``'No space left on device'``-style reason of an ``OSError`` (its strerror, else its text)."""
    return error.strerror or str(error) or type(error).__name__


def temporary_path(path: Path) -> Path:
    """Where [`atomic_write`][tableclean_suite.atomic_files.atomic_write] writes ``path`` first: a hidden
    name in the same directory."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def write_temporary(path: Path, write: Callable[[Path], None]) -> Path:
    """``write`` the contents of ``path`` to its [temporary][tableclean_suite.atomic_files.temporary_path]
    and return that; on failure the temporary is removed and a file-system error is raised as
    [`OutputError`][tableclean_suite.atomic_files.OutputError]."""
    temporary = temporary_path(path)
    try:
        write(temporary)
    except OSError as error:
        remove_quietly(temporary)
        if isinstance(error, OutputError):
            raise
        raise OutputError(f"cannot write {str(path)!r}: {describe_os_error(error)}") from None
    except BaseException:
        remove_quietly(temporary)
        raise
    return temporary


def replace(temporary: Path, path: Path) -> None:
    """`os.replace` ``temporary`` over ``path``; an
    [`OutputError`][tableclean_suite.atomic_files.OutputError] naming ``path`` if it fails."""
    try:
        os.replace(temporary, path)
    except OSError as error:
        raise OutputError(f"cannot write {str(path)!r}: {describe_os_error(error)}") from None


def atomic_write(path, write: Callable[[Path], None]) -> Path:
    """Create or replace ``path`` atomically with what ``write(temporary)`` writes; returns ``path``.
    On failure ``path`` is unchanged, the temporary removed, a file-system error raised as
    [`OutputError`][tableclean_suite.atomic_files.OutputError]."""
    path = Path(path)
    temporary = write_temporary(path, write)
    try:
        replace(temporary, path)
    finally:
        remove_quietly(temporary)  # left only by a failed replace
    return path


def remove_quietly(path: Path) -> None:
    """Delete ``path`` if it exists; a failure to delete is ignored."""
    try:
        path.unlink(missing_ok=True)
    except OSError:
        pass  # e.g. the temporary's name is a directory: nothing of ours to remove


def atomic_write_text(path, text: str) -> Path:
    """[`atomic_write`][tableclean_suite.atomic_files.atomic_write] of UTF-8 text."""
    return atomic_write(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))
