"""Rule finish_refine: the finished loop's outputs (pidpipe.steps.refine.finish_refine)."""

from pidpipe.steps.refine import finish_refine
from pidpipe.steps.run import run_step

run_step(
    finish_refine,
    snakemake.log[0],
    refine_dir=snakemake.params.refine_dir,
    design_table=snakemake.output.table,
)
