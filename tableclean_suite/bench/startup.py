"""One notice before numba compiles the package's kernels (`announce_compiles`), during which Ctrl-C
ends the process in one line."""

from __future__ import annotations

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
        if _NOTICE["depth"] == 1 and signal.getsignal(signal.SIGINT) is signal.default_int_handler:
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
