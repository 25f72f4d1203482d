"""pidpipe: particle impact damper design for honeycomb sandwich panels.

The package follows the data through the pipeline; each folder imports only those above it:

- :mod:`pidpipe.config`       ``config.yaml`` validated against its JSON schema, and what follows
- :mod:`pidpipe.physics`      contact mechanics and the equivalent damping C_eq = E_d/(pi omega W^2)
- :mod:`pidpipe.cases`        the grid of cases (f, G, r, replicate) and their ids
- :mod:`pidpipe.cell`         the hexagonal cell, patches and rows of cells, the packings inside
- :mod:`pidpipe.measurement`  per-cycle statistics, steady state, the timestep plan, adaptive runs
- :mod:`pidpipe.liggghts`     decks, the LIGGGHTS process, its output; pouring and shaking
- :mod:`pidpipe.dem`          the in-repo DEM of the same cell, the second solver
- :mod:`pidpipe.design`       the C_eq table, its surrogate, the optimisation under the budget
- :mod:`pidpipe.figures`      surrogate maps, convergence histories, the fidelity figure
- :mod:`pidpipe.studies`      fidelity, scene and validation studies
- :mod:`pidpipe.steps`        the Snakemake workflow's steps, one module per stage
- :mod:`pidpipe.cli`          the ``pidpipe`` command

:mod:`pidpipe.errors` (the exceptions) and :mod:`pidpipe.files` (atomic writes) serve them all.
"""

__version__ = "0.1.0"
