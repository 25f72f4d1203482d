"""Rule plot_convergence: SLSQP convergence (pidpipe.steps.figures.plot_optimisation_convergence)."""

from pidpipe.steps.figures import plot_optimisation_convergence
from pidpipe.steps.run import run_step

run_step(
    plot_optimisation_convergence,
    snakemake.log[0],
    results_json=snakemake.input.results,
    png=snakemake.output.png,
)
