"""Checkpoint refine_step: one step of the refinement loop (pidpipe.steps.refine.refine_step)."""

from pidpipe.steps.refine import refine_step
from pidpipe.steps.run import run_step

run_step(
    refine_step,
    snakemake.log[0],
    config=dict(snakemake.config),
    grid_table=snakemake.input.table,
    refine_dir=snakemake.params.refine_dir,
    step_path=snakemake.output.step,
)
