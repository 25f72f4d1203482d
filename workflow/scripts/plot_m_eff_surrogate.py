"""Rule plot_m_eff_surrogate: m_eff / bed mass maps (pidpipe.steps.figures.plot_m_eff_maps)."""

from pidpipe.steps.figures import plot_m_eff_maps
from pidpipe.steps.run import run_step

run_step(
    plot_m_eff_maps,
    snakemake.log[0],
    surrogate_path=snakemake.input.surrogate,
    table_path=snakemake.input.table,
    freq_fill_png=snakemake.output.freq_fill,
    freq_accel_png=snakemake.output.freq_accel,
)
