"""Rule check_panel_mode: the DEM check of a mode (pidpipe.steps.panel.check_panel_mode)."""

from pidpipe.steps.panel import check_panel_mode
from pidpipe.steps.run import run_step

run_step(
    check_panel_mode,
    snakemake.log[0],
    config=snakemake.params.config,
    surrogate_path=snakemake.input.surrogate,
    layout_path=snakemake.input.layout,
    curves_path=snakemake.output.curves,
    summary_path=snakemake.output.summary,
    meta_path=snakemake.output.meta,
    folder=snakemake.params.folder,
    workers=snakemake.threads,
    m_eff_surrogate_path=next(iter(snakemake.input.m_eff_surrogate), None),
)
