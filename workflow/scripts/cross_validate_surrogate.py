"""Rule cross_validate_surrogate: leave-one-out errors (pidpipe.steps.design.cross_validate_table).

The call is guarded: the folds' worker processes start by importing this script
(multiprocessing's spawn), and must not run the step again."""

import os

# Snakemake sets OPENBLAS_NUM_THREADS (and OMP_, MKL_) to the rule's threads; a BLAS on two
# threads rounds differently. The threads are for worker processes: BLAS stays on one, so the
# results are those of threads: 1.
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")

from pidpipe.steps.design import cross_validate_table  # noqa: E402
from pidpipe.steps.run import run_step  # noqa: E402

if __name__ == "__main__":
    run_step(
        cross_validate_table,
        snakemake.log[0],
        table_path=snakemake.input.table,
        cv_path=snakemake.output.cv,
        workers=snakemake.threads,
    )
