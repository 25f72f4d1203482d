"""Rule plot_scene: C_eq per cell and CPU time against scene size (pidpipe.studies.scene.plot_scenes)."""

from pidpipe.steps.run import run_step
from pidpipe.studies.scene import plot_table

run_step(plot_table, snakemake.log[0], table_path=snakemake.input.table, png=snakemake.output.png)
