"""Rule validate: LIGGGHTS against the NumPy DEM (pidpipe.steps.validate.validate_against_dem)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.validate import validate_against_dem

run_step(
    validate_against_dem,
    snakemake.log[0],
    config=snakemake.params.config,
    cases=snakemake.params.cases,
    packing_paths=list(snakemake.input.packings),
    table_path=snakemake.output.table,
    plot_path=snakemake.output.plot,
    workdir=snakemake.params.workdir,
)
