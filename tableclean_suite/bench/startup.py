"""What a command says while it starts: robosuite's start-up messages kept off the harness's
output unless asked for, and one notice before numba compiles the package's kernels
(`announce_compiles`).

When robosuite is imported (by the physics backend, or by anything else that needs MuJoCo) it
logs warnings about its own installation: no private macro file, no robosuite_models, no mink.
They say nothing about a benchmark run, so the commands drop them unless ``--verbose``
(`quiet_robosuite_startup`).  Only records logged while robosuite itself is being imported
are dropped; its later messages (e.g. about a controller) pass as usual.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

import wrapt

from tableclean_suite.robosuite_adapter import (  # noqa: F401  (part of this module's interface)
    ROBOSUITE_LOGGER,
    apply_verbosity,
    quiet_robosuite_startup,
)

#: Exit status after Ctrl-C (the shell's 128 + SIGINT).
EXIT_INTERRUPTED = 130
#: Wall seconds a command spends compiling its kernels when numba's disk cache is empty (measured:
#: the smallest scaling study, 60-120 s on a busy 2-core machine; the physics commands take longer).
COMPILE_SECONDS = 90
#: The package whose kernels `announce_compiles` announces.
PACKAGE = "tableclean_suite"


_NOTICE = {"installed": False, "said": False, "prog": "tableclean-bench", "depth": 0, "previous": None}


def _interrupted_while_compiling(_signum, _frame) -> None:
    """Ctrl-C while numba compiles: one line and exit 130 at once.  Raised inside a compilation,
    ``KeyboardInterrupt`` can land in one of llvmlite's ctypes callbacks, which prints it as an
    ignored exception and goes on; nothing is published while a kernel compiles, so there is
    nothing to finish."""
    sys.stdout.flush()
    print(f"{_NOTICE['prog']}: interrupted", file=sys.stderr, flush=True)
    os._exit(EXIT_INTERRUPTED)


def _compiling(started: bool) -> None:
    """Count nested compilations; during the outermost, Ctrl-C ends the process in one line (only in
    the main thread, and not where Ctrl-C is ignored, as in the harness's worker processes)."""
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
    """From numba's import on, print one line on stderr before the first of the package's kernels
    is compiled in this process, and end the process in one line (exit 130, as ``prog``) on Ctrl-C
    during any compilation.  numba reports a compilation only when its disk cache misses, so
    the notice appears on a first use (or after an edit) and never when the cache serves."""
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
