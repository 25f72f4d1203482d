"""pidpipe: particle impact damper design for honeycomb sandwich panels.

The package is organised by pipeline stage:

- :mod:`pidpipe.config`       load and validate ``config.yaml`` against its JSON schema
- :mod:`pidpipe.contact`      Hertz/Tsuji contact constants, Rayleigh time, contact duration
- :mod:`pidpipe.geometry`     the hexagonal honeycomb cell and its STL wall mesh
- :mod:`pidpipe.fill`         fill percent -> sphere count
- :mod:`pidpipe.packing`      seeded, settled sphere packings inside the closed cell
- :mod:`pidpipe.decks`        LIGGGHTS decks rendered from validated values only
- :mod:`pidpipe.engine`       running LIGGGHTS, turning its failures into clear errors
- :mod:`pidpipe.parsing`      reading LIGGGHTS' energy output
- :mod:`pidpipe.damping`      dissipated energy per cycle -> C_eq with its uncertainty
- :mod:`pidpipe.case`         one case end to end, as a machine-readable record
- :mod:`pidpipe.surrogate`    spline surrogates of C_eq over (f, G, r)
- :mod:`pidpipe.optimisation` SLSQP multi-start optimisation under the particle budget
- :mod:`pidpipe.dem`          an independent NumPy DEM of one cell, for validation
- :mod:`pidpipe.cli`          the ``pidpipe`` command
"""

__version__ = "0.1.0"
