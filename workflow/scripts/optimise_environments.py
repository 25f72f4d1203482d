"""Rule optimise_environments: every design of every environment, bootstrapped (pidpipe.steps.design.optimise_surrogate)."""

import os

# Snakemake sets OPENBLAS_NUM_THREADS (and OMP_, MKL_) to the rule's threads; a BLAS on two
# threads rounds differently and moves the optimum in its 8th digit. The threads are for the
# bootstrap's worker processes: BLAS stays on one, so the results are those of threads: 1.
os.environ.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")

from pidpipe.steps.design import optimise_surrogate  # noqa: E402
from pidpipe.steps.run import run_step  # noqa: E402

run_step(
    optimise_surrogate,
    snakemake.log[0],
    surrogate_path=snakemake.input.surrogate,
    environments=snakemake.params.environments,
    budget=snakemake.params.budget,
    optimisation=snakemake.params.optimisation,
    results_csv=snakemake.output.results,
    history_csv=snakemake.output.history,
    results_json=snakemake.output.json,
    bootstrap_csv=snakemake.output.bootstrap,
    workers=snakemake.threads,
    cv_path=snakemake.input.cv,
)
