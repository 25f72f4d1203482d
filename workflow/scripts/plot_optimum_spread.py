"""Rule plot_optimum_spread: the bootstrap's designs (pidpipe.steps.figures.plot_optimum_spread_figure)."""

from pidpipe.steps.figures import plot_optimum_spread_figure
from pidpipe.steps.run import run_step

run_step(
    plot_optimum_spread_figure,
    snakemake.log[0],
    results_json=snakemake.input.results,
    bootstrap_csv=snakemake.input.bootstrap,
    png=snakemake.output.png,
)
