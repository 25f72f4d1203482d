"""Studies on top of the pipeline: fidelity against CPU, scenes (cells against patches), LIGGGHTS against the DEM."""
