"""Checkpoint refine_step: one step of the refinement loop (pidpipe.steps.refine.refine_step).

The call is guarded: with refine.run_cases in_step the step's worker processes start by
importing this script (multiprocessing's spawn), and must not run the step again."""

import os

# Snakemake sets OPENBLAS_NUM_THREADS (and OMP_, MKL_) to the rule's threads; a BLAS on two
# threads rounds differently. The threads are for worker processes: BLAS stays on one, so the
# results are those of threads: 1.
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")

from pidpipe.steps.refine import refine_step  # noqa: E402
from pidpipe.steps.run import run_step  # noqa: E402

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
