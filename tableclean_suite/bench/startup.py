"""Ctrl-C in a command: raised where it cannot be lost (`catch_ctrl_c`), and one notice before numba compiles
the package's kernels (`announce_compiles`), during which Ctrl-C ends the process in one line."""

from __future__ import annotations

import _thread
import contextlib
import os
import signal
import sys
import threading

import wrapt

#: Exit status after Ctrl-C (the shell's 128 + SIGINT).
EXIT_INTERRUPTED = 130

#: Wall seconds of compiling the kernels with numba's disk cache empty (60-120 s on 2 busy cores).
COMPILE_SECONDS = 90
PACKAGE = "tableclean_suite"

#: Seconds after which a Ctrl-C that landed inside an import is delivered again.
CTRL_C_RETRY_SECONDS = 0.05


#: The pending re-delivery of a Ctrl-C that landed where it could be lost (at most one).
_RETRY: dict = {"timer": None}


def _swallowed_here(frame) -> bool:
    """Whether a ``KeyboardInterrupt`` raised in ``frame`` can be lost: under Python's import machinery (an
    extension module's initialisation clears errors raised in its Python callbacks, e.g. a Cython module's
    ``abc.register`` calls) or under an llvmlite callback from LLVM (ctypes prints and drops its errors)."""
    while frame is not None:
        where = frame.f_code.co_filename
        if where.startswith("<frozen importlib._bootstrap") or "llvmlite" in where:
            return True
        frame = frame.f_back
    return False


def _ctrl_c(_signum, frame) -> None:
    """``KeyboardInterrupt``, or, where it could be lost (`_swallowed_here`), the signal again
    `CTRL_C_RETRY_SECONDS` later, until it lands where it is raised."""
    if not _swallowed_here(frame):
        _RETRY["timer"] = None
        raise KeyboardInterrupt
    if _RETRY["timer"] is None or not _RETRY["timer"].is_alive():
        _RETRY["timer"] = threading.Timer(CTRL_C_RETRY_SECONDS, _thread.interrupt_main)
        _RETRY["timer"].daemon = True
        _RETRY["timer"].start()


@contextlib.contextmanager
def catch_ctrl_c():
    """In the main thread, while Ctrl-C has Python's default handler: handle it with `_ctrl_c` for the block
    (the default handler is back after it, unless the block set another).  A Ctrl-C still waiting to be
    delivered again when the block ends is raised there, as ``KeyboardInterrupt``."""
    installed = threading.current_thread() is threading.main_thread() and \
        signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if installed:
        signal.signal(signal.SIGINT, _ctrl_c)
    try:
        yield
    finally:
        pending, _RETRY["timer"] = _RETRY["timer"], None
        if pending is not None:
            pending.cancel()
        if installed and signal.getsignal(signal.SIGINT) is _ctrl_c:
            signal.signal(signal.SIGINT, signal.default_int_handler)
    if pending is not None:
        raise KeyboardInterrupt


_NOTICE = {"installed": False, "said": False, "prog": "tableclean-bench", "depth": 0, "previous": None}


def _interrupted_while_compiling(_signum, _frame) -> None:
    """Ctrl-C while numba compiles: one line and exit 130 at once (raised, ``KeyboardInterrupt`` can land in an
    llvmlite callback that ignores it; nothing is published while a kernel compiles)."""
    sys.stdout.flush()
    print(f"{_NOTICE['prog']}: interrupted", file=sys.stderr, flush=True)
    os._exit(EXIT_INTERRUPTED)


def _compiling(started: bool) -> None:
    """Count nested compilations; during the outermost, Ctrl-C ends the process (main thread, Ctrl-C not ignored)."""
    if threading.current_thread() is not threading.main_thread():
        return
    if started:
        _NOTICE["depth"] += 1
        if _NOTICE["depth"] == 1 and signal.getsignal(signal.SIGINT) in (signal.default_int_handler, _ctrl_c):
            _NOTICE["previous"] = signal.signal(signal.SIGINT, _interrupted_while_compiling)
    else:
        _NOTICE["depth"] = max(0, _NOTICE["depth"] - 1)
        if _NOTICE["depth"] == 0 and _NOTICE["previous"] is not None:
            signal.signal(signal.SIGINT, _NOTICE["previous"])
            _NOTICE["previous"] = None


def announce_compiles(prog: str = "tableclean-bench") -> None:
    """From numba's import on, print one line on stderr before the package's first kernel compiles in this
    process (a disk-cache miss), and end the process in one line (exit 130, as ``prog``) on Ctrl-C during
    any compilation."""
    _NOTICE["prog"] = prog

    def install(_numba) -> None:
        from numba.core import event

        class Notice(event.Listener):
            def on_start(self, happening) -> None:
                _compiling(True)
                function = getattr(happening.data.get("dispatcher"), "py_func", None)
                if not _NOTICE["said"] and getattr(function, "__module__", "").startswith(PACKAGE):
                    _NOTICE["said"] = True
                    print(f"compiling kernels once, about {COMPILE_SECONDS} s (numba caches them for later runs)",
                          file=sys.stderr, flush=True)

            def on_end(self, happening) -> None:
                _compiling(False)

        event.register("numba:compile", Notice())

    if _NOTICE["installed"]:
        return
    _NOTICE["installed"] = True
    if "numba" in sys.modules:  # wrapt does not call a hook added after the import's own hooks ran
        install(sys.modules["numba"])
    else:
        wrapt.register_post_import_hook(install, "numba")
