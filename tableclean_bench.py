"""The ``tableclean-bench`` console script.

It lives outside the package so that Ctrl-C while ``tableclean_suite`` itself is still being
imported ends in one line and exit 130, like Ctrl-C at any later moment
([`main`][tableclean_suite.bench.commands.main] handles those).
"""

import signal
import sys


def main() -> int:
    """Import the commands and run the one ``sys.argv`` names; Ctrl-C during the import is one line."""
    try:
        from tableclean_suite.bench.commands import main as run_command
    except KeyboardInterrupt:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        print("tableclean-bench: interrupted", file=sys.stderr)
        return 130
    return run_command()
