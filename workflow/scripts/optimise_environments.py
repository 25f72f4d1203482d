"""Rule optimise_environments: every design of every environment, bootstrapped (pidpipe.steps.design.optimise_surrogate)."""

from pidpipe.steps.design import optimise_surrogate
from pidpipe.steps.run import run_step

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
)
