"""``python -m tableclean_suite.bench.scaling``: run the scaling study (see `tableclean_suite.bench.scaling`)."""

import sys

from tableclean_suite.bench.scaling.command import main

if __name__ == "__main__":
    sys.exit(main(prog="python -m tableclean_suite.bench.scaling"))
