"""Rule pour_dem_packings: pour every packing of one fill in one batch (pidpipe.steps.packings.pour_packings)."""

from pidpipe.steps.packings import pour_packings
from pidpipe.steps.run import run_step

run_step(
    pour_packings,
    snakemake.log[0],
    config=snakemake.params.config,
    fill_pct=snakemake.wildcards.fill,
    replicates=snakemake.params.replicates,
    packing_paths=list(snakemake.output.packings),
    workdirs=snakemake.params.workdirs,
)
