"""Writing a run's output files so that they always describe one run, whatever interrupts it.

Protocol of :func:`publish` (``OUT`` is the output directory):

1. ``OUT/config.json`` is deleted.  From here until step 3 no file claims to describe a run.
2. Each data file (``table3.csv``, ``table4.csv``, ``curves.csv``, the figures) is written to a
   temporary name in ``OUT`` (``.NAME.PID.tmp``) and moved over the old one with
   :func:`os.replace`, so each is at any moment either entirely the old or entirely the new one.
3. ``config.json`` is written last, the same way, with a fresh ``run_id`` and, under ``files``,
   the SHA-256 and size of every data file of the run.

Hence: when ``config.json`` exists, the data files it lists are the ones of its run
(:func:`check_outputs` verifies the digests); when it is missing, the last run did not finish
writing and the directory describes no run.  An interrupted run leaves at most temporary
files behind (removed when their writer fails in Python; a killed process can leave one).
"""

from __future__ import annotations

import hashlib
import json
import os
import uuid
from pathlib import Path
from typing import Callable

#: The manifest: the run's configuration, its id and the digests of its data files.
MANIFEST = "config.json"

#: Bytes read at a time when hashing a file.
_HASH_BLOCK = 1 << 20


def temporary_path(path: Path) -> Path:
    """Where :func:`atomic_write` writes ``path`` first: a hidden name in the same directory."""
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def atomic_write(path, write: Callable[[Path], None]) -> Path:
    """Create or replace ``path`` atomically: ``write(temporary)`` then :func:`os.replace`.

    Args:
        path: the final file.
        write: writes the complete contents to the path it is given.

    Returns:
        ``path``.  If ``write`` or the replace fails, ``path`` is unchanged and the temporary
        file is removed.
    """
    path = Path(path)
    temporary = temporary_path(path)
    try:
        write(temporary)
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path, text: str) -> Path:
    """:func:`atomic_write` of UTF-8 text."""
    return atomic_write(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))


def sha256_file(path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(_HASH_BLOCK), b""):
            digest.update(block)
    return digest.hexdigest()


def publish(out, writers: dict[str, Callable[[Path], None]], manifest: dict) -> list[Path]:
    """Write a run's data files and its manifest following the module's protocol.

    Args:
        out: the output directory (must exist).
        writers: ``{file name: write(path)}`` of the data files, written in this order.
        manifest: the run's description; ``run_id`` and ``files`` are added to it.

    Returns:
        The paths written, data files first and ``config.json`` last.
    """
    out = Path(out)
    (out / MANIFEST).unlink(missing_ok=True)
    written, files = [], {}
    for name, write in writers.items():
        path = atomic_write(out / name, write)
        files[name] = {"sha256": sha256_file(path), "bytes": path.stat().st_size}
        written.append(path)
    document = {**manifest, "run_id": uuid.uuid4().hex, "files": files}
    written.append(atomic_write_text(out / MANIFEST, json.dumps(document, indent=2)))
    return written


def check_outputs(out) -> list[str]:
    """Problems of an output directory; ``[]`` when ``config.json`` and its data files agree.

    A missing ``config.json`` (a run that did not finish writing) is a problem too.
    """
    out = Path(out)
    try:
        document = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    except FileNotFoundError:
        return [f"{out / MANIFEST} is missing: the last run did not finish writing its outputs"]
    except (OSError, ValueError) as error:
        return [f"{out / MANIFEST} is unreadable: {error}"]
    files = document.get("files")
    if not isinstance(files, dict) or "run_id" not in document:
        return [f"{out / MANIFEST} has no run_id or files list (written by an older version?)"]
    problems = []
    for name, facts in files.items():
        path = out / name
        if not path.is_file():
            problems.append(f"{path} is missing")
        elif sha256_file(path) != facts.get("sha256"):
            problems.append(f"{path} is not the file of run {document['run_id']} (SHA-256 differs)")
    return problems


def check_writable(out) -> str | None:
    """Why ``out`` cannot be used as an output directory, or None if it can.

    Creates ``out`` (and its parents) if missing and writes and removes a probe file in it, so
    the answer is the file system's, permissions, read-only mounts and full disks included.
    """
    out = Path(out)
    for parent in (out, *out.parents):
        if parent.exists():
            if not parent.is_dir():
                where = "is a file" if parent == out else f"is under {str(parent)!r}, which is a file"
                return f"{str(out)!r} {where}, not a directory"
            break
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".write-probe.{os.getpid()}.tmp"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as error:
        return f"{str(out)!r} is not writable ({error.strerror or error})"
    return None
