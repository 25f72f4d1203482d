"""Rule plot_host: the host check's curves (pidpipe.steps.host.plot_host_figure)."""

from pidpipe.steps.host import plot_host_figure
from pidpipe.steps.run import run_step

run_step(
    plot_host_figure,
    snakemake.log[0],
    curves_path=snakemake.input.curves,
    png=snakemake.output.png,
)
