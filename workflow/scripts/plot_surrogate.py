"""Rule plot_surrogate: C_eq maps of the surrogate (pidpipe.campaign.plot_surrogate_maps)."""

from pidpipe.campaign import plot_surrogate_maps, run_step

run_step(
    plot_surrogate_maps,
    snakemake.log[0],
    surrogate_path=snakemake.input.surrogate,
    freq_fill_stem=snakemake.params.freq_fill_stem,
    freq_accel_stem=snakemake.params.freq_accel_stem,
)
