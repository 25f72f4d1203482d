"""Rule plot_convergence: SLSQP convergence (pidpipe.campaign.plot_optimisation_convergence)."""

from pidpipe.campaign import plot_optimisation_convergence, run_step

run_step(
    plot_optimisation_convergence,
    snakemake.log[0],
    results_json=snakemake.input.results,
    png=snakemake.output.png,
)
