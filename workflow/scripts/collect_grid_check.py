"""Rule validate: the grid check's table and parity figure (pidpipe.steps.validate.collect_grid_check)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.validate import collect_grid_check

run_step(
    collect_grid_check,
    snakemake.log[0],
    liggghts_paths=list(snakemake.input.liggghts),
    dem_paths=list(snakemake.input.dem),
    table_path=snakemake.output.table,
    plot_path=snakemake.output.plot,
)
