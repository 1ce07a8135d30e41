"""``python -m tableclean_suite.bench COMMAND``: every benchmark command (see `commands`)."""

import sys

from tableclean_suite.bench.commands import main

if __name__ == "__main__":
    sys.exit(main(prog="python -m tableclean_suite.bench"))
