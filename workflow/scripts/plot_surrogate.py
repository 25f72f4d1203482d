"""Rule plot_surrogate: C_eq maps of the surrogate (pidpipe.steps.figures.plot_surrogate_maps)."""

from pidpipe.steps.figures import plot_surrogate_maps
from pidpipe.steps.run import run_step

run_step(
    plot_surrogate_maps,
    snakemake.log[0],
    surrogate_path=snakemake.input.surrogate,
    freq_fill_png=snakemake.output.freq_fill,
    freq_accel_png=snakemake.output.freq_accel,
    draws=snakemake.params.uncertainty["draws"],
    seed=snakemake.params.uncertainty["seed"],
)
