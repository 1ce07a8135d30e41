"""Writing a command's output folder so that it always describes one publication, whatever interrupts it.

[`publish`][tableclean_suite.bench.outputs.publish], under the folder's lock, writes the data files and
the manifest (``config.json``: the command, its configuration, a ``run_id`` and each data file's
SHA-256 and size) to temporaries, then moves the manifest to ``.publishing.json``, deletes the files
of earlier publications it does not rewrite and ``config.json``, moves each data file in and
``.publishing.json`` to ``config.json`` last.  So when ``config.json`` exists, the files it lists are
its publication's; when it is missing, the last publication was interrupted.  A folder holding
another command's publication, or a ``config.json`` this suite did not write, is refused, never
deleted.  Every failure is an [`OutputError`][tableclean_suite.atomic_files.OutputError] (an ``OSError``)
whose message is one line naming the path and the reason.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
import uuid
from contextlib import contextmanager
from pathlib import Path
from typing import Callable

from tableclean_suite.atomic_files import (OutputError, atomic_write, atomic_write_text,  # noqa: F401 (exported)
                                           describe_os_error, remove_quietly, replace, temporary_path, write_temporary)

#: The manifest, and the new one while its files move in (left behind only by an interrupted publication).
MANIFEST, PENDING = "config.json", ".publishing.json"
#: The command of a manifest without a ``command`` key (written before commands were recorded).
LEGACY_COMMAND = "run"
_HASH_BLOCK = 1 << 20
#: Keys that mark a manifest as written by [`publish`][tableclean_suite.bench.outputs.publish].
_MANIFEST_KEYS = ("run_id", "files")


class OutputBusyError(OutputError):
    """Another process holds the output folder's lock ([`output_lock`][tableclean_suite.bench.outputs.output_lock])."""


def check_out_path(out) -> Path:
    """``out`` as a `Path`; [`OutputError`][tableclean_suite.atomic_files.OutputError] for an empty or blank name."""
    if out is None or (isinstance(out, str) and not out.strip()):
        raise OutputError(f"output folder {out!r} is empty; name a folder (e.g. results/run1)")
    return Path(out)


def sha256_file(path) -> str:
    """SHA-256 (hex) of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(_HASH_BLOCK), b""):
            digest.update(block)
    return digest.hexdigest()


_HELD_LOCKS: dict = {}


@contextmanager
def output_lock(out, wait: float = 0.0):
    """Hold an exclusive ``flock`` on the folder ``out`` (created if missing) itself while writing into it:
    re-entrant within a process, released when the holder exits or is killed.

    Raises:
        OutputBusyError: another process holds it after ``wait`` seconds (0: refuse at once).
        OutputError: the folder cannot be created or opened.
    """
    import fcntl

    out = check_out_path(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
        descriptor = os.open(out, os.O_RDONLY | os.O_DIRECTORY | os.O_CLOEXEC)
    except OSError as error:
        raise OutputError(f"output folder {str(out)[:200]!r} cannot be used: {describe_os_error(error)}") from None
    key = os.fstat(descriptor).st_ino, os.fstat(descriptor).st_dev
    try:
        if key not in _HELD_LOCKS:
            deadline = time.monotonic() + wait
            while True:
                try:
                    fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
                    break
                except BlockingIOError:
                    if time.monotonic() >= deadline:
                        raise OutputBusyError(f"output folder {str(out)!r} is in use by another run; wait for it to "
                                              "finish or choose another output folder") from None
                    time.sleep(0.1)
        _HELD_LOCKS[key] = _HELD_LOCKS.get(key, 0) + 1
        try:
            yield out
        finally:
            _HELD_LOCKS[key] -= 1
            if not _HELD_LOCKS[key]:
                del _HELD_LOCKS[key]
    finally:
        os.close(descriptor)  # the last descriptor of the folder closed releases the flock


def _manifest_of(path) -> dict | None:
    """The manifest at ``path`` if [`publish`][tableclean_suite.bench.outputs.publish] wrote it, else None."""
    try:
        document = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if isinstance(document, dict) and document.get("study") == "scaling" and "run_id" not in document:
        return {"command": "scaling", "run_id": None, "files": {}}  # scaling's config.json before it had a manifest
    return document if isinstance(document, dict) and all(key in document for key in _MANIFEST_KEYS) else None


def publication_problem(out, command: str) -> str | None:
    """Why ``command`` may not publish into ``out``, or None: a ``config.json`` this suite did not
    write (never deleted), or the publication of another command (named)."""
    path = Path(out) / MANIFEST
    if not path.exists():
        return None
    document = _manifest_of(path)
    if document is None:
        return (f"{str(path)!r} exists and was not written by tableclean_suite; it is left alone: choose another "
                "output folder")
    other = document.get("command", LEGACY_COMMAND)
    if other != command:
        return (f"{str(out)!r} holds the outputs of 'tableclean-bench {other}' ({MANIFEST}); {command} does not "
                f"replace them: choose another output folder")
    return None


def arguments(args) -> dict:
    """A parsed command line's plain values (text, numbers, lists of them), for a manifest."""
    plain = (str, int, float, bool, type(None))
    return {key: list(value) if isinstance(value, (list, tuple)) else value for key, value in vars(args).items()
            if isinstance(value, plain)
            or isinstance(value, (list, tuple)) and all(isinstance(v, plain) for v in value)}


def publish(out, writers: dict[str, Callable[[Path], None]], manifest: dict, wait: float = 60.0,
            command: str = LEGACY_COMMAND, kept=()) -> list[Path]:
    """Write ``command``'s data files (``writers``: ``{file name: write(path)}``, in order) and its
    ``manifest`` (``command``, ``run_id``, ``files`` and ``kept`` added) into ``out`` as the module says,
    waiting up to ``wait`` seconds for the folder's lock.  ``kept``: files of ``out`` kept across
    publications (e.g. a study database).

    Returns:
        The paths written, data files first and ``config.json`` last.

    Raises:
        OutputError: a file cannot be written (the last publication is left as it was), or the folder
            holds another command's publication or a ``config.json`` this suite did not write.
    """
    out = check_out_path(out)
    with output_lock(out, wait):
        problem = publication_problem(out, command)
        if problem:
            raise OutputError(problem)
        earlier = {name for path in (out / MANIFEST, out / PENDING)
                   for name in (_manifest_of(path) or {}).get("files", ())}
        staged: list[tuple[Path, Path]] = []
        try:
            files = {}
            for name, write in writers.items():
                path = out / name
                temporary = _stage(path, write)
                staged.append((temporary, path))
                files[name] = {"sha256": sha256_file(temporary), "bytes": temporary.stat().st_size}
            document = {**manifest, "command": command, "run_id": uuid.uuid4().hex, "files": files, "kept": list(kept)}
            text = json.dumps(document, indent=2)
            replace(_stage(out / MANIFEST, lambda t: t.write_text(text, encoding="utf-8")), out / PENDING)
            for name in sorted(earlier - set(files) - {MANIFEST, PENDING}):
                if Path(name).name == name:  # a file of the folder itself, never one a name leads elsewhere
                    _unlink(out / name)  # config.json, still listing it, reports it missing until replaced
            _unlink(out / MANIFEST)
            for temporary, path in staged:
                replace(temporary, path)
            replace(out / PENDING, out / MANIFEST)
        finally:
            for temporary in (*(t for t, _ in staged), temporary_path(out / MANIFEST)):
                remove_quietly(temporary)
    return [path for _, path in staged] + [out / MANIFEST]


def _stage(path: Path, write: Callable[[Path], None]) -> Path:
    """Write ``path``'s temporary; OutputError (temporary removed) if it cannot be or ``path`` is a folder."""
    if path.is_dir():
        raise OutputError(f"cannot write {str(path)!r}: it is a folder; remove it or choose another output folder")
    return write_temporary(path, write)


def _unlink(path: Path) -> None:
    try:
        path.unlink(missing_ok=True)
    except OSError as error:
        raise OutputError(f"cannot replace {str(path)!r}: {describe_os_error(error)}") from None


def check_writable(out) -> str | None:
    """Why ``out`` cannot be used as an output directory, or None: creates it if missing and writes and
    removes a probe file in it, so the answer is the file system's (permissions, read-only, full disk)."""
    if out is None or (isinstance(out, str) and not out.strip()):
        return f"{out!r} is empty (it would mean the current directory); name a folder"
    out = Path(out)
    try:
        problem = file_in_the_way(out)
        if problem:
            return problem
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".write-probe.{os.getpid()}.tmp"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as error:
        return f"{str(out)!r} is not writable ({describe_os_error(error)})"
    return None


def file_in_the_way(path: Path, itself: bool = True) -> str | None:
    """Why ``path`` cannot be a directory (it, with ``itself``, or a parent is a file), or None.

    Raises:
        OSError: a parent cannot be searched.
    """
    for parent in (path, *path.parents) if itself else path.parents:
        if parent.exists():
            if parent.is_dir():
                return None
            where = "is a file" if parent == path else f"is under {str(parent)!r}, which is a file"
            return f"{str(path)!r} {where}, not a directory"
    return None


def check_publishable(out, folders=(), command: str = LEGACY_COMMAND) -> str | None:
    """Why ``command`` could not [`publish`][tableclean_suite.bench.outputs.publish] into ``out``, or None:
    ``out`` or one of its sub-``folders`` not writable, another command's publication or a foreign
    ``config.json``.  Call it before any work."""
    problem = check_writable(out)
    for folder in folders:
        problem = problem or check_writable(Path(out) / folder)
    return problem or publication_problem(out, command)
