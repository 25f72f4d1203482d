"""Checkpoint refine_step: one step of the refinement loop (pidpipe.steps.refine.refine_step).

The call is guarded: with refine.run_cases in_step the step's worker processes start by
importing this script (multiprocessing's spawn), and must not run the step again."""

from pidpipe.steps.refine import refine_step
from pidpipe.steps.run import run_step

if __name__ == "__main__":
    run_step(
        refine_step,
        snakemake.log[0],
        config=dict(snakemake.config),
        grid_table=snakemake.input.table,
        refine_dir=snakemake.params.refine_dir,
        step_path=snakemake.output.step,
        cores=snakemake.threads,
    )
