"""Rule plot_scene: C_eq per cell and CPU time against scene size (pidpipe.scene_study.plot_scenes)."""

from pidpipe.campaign import run_step
from pidpipe.scene_study import plot_table

run_step(plot_table, snakemake.log[0], table_path=snakemake.input.table, png=snakemake.output.png)
