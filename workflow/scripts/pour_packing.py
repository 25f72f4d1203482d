"""Rule pour_packing: pour and settle one packing (pidpipe.steps.packings.pour_packing)."""

from pidpipe.steps.packings import pour_packing
from pidpipe.steps.run import run_step

run_step(
    pour_packing,
    snakemake.log[0],
    config=snakemake.params.config,
    fill_pct=snakemake.wildcards.fill,
    replicate=snakemake.wildcards.replicate,
    packing_path=snakemake.output[0],
    workdir=snakemake.params.workdir,
)
