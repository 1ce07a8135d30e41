"""The benchmark harness: reproduce the paper's Tables 3-4 and Figures 3-7, and measure the skills.

Ships with the package, so an installed ``tableclean_suite`` runs it without the source checkout::

    python -m tableclean_suite.bench.run --help

The checkout's ``benchmarks/`` folder keeps thin ``python -m benchmarks.X`` entry points to these modules.
"""
