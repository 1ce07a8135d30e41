"""The benchmark commands: reproduce the paper's Tables 3-4 and Figures 3-7, and measure the skills.

Ships with the package, so an installed ``tableclean_suite`` runs them without the source checkout:

    tableclean-bench --help                    # the commands (python -m tableclean_suite.bench --help)
    tableclean-bench COMMAND --help

`commands` is the registry; the checkout's ``benchmarks/`` folder keeps thin
``python -m benchmarks.X`` aliases of the commands.
"""
