"""Rule validate: LIGGGHTS against the NumPy DEM (pidpipe.campaign.validate_against_dem)."""

from pidpipe.campaign import run_step, validate_against_dem

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
