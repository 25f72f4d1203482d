"""Rule design_panel: the panel's modes and layouts (pidpipe.steps.panel.panel_step)."""

from pidpipe.steps.panel import panel_step
from pidpipe.steps.run import run_step

run_step(
    panel_step,
    snakemake.log[0],
    config=snakemake.params.config,
    surrogate_path=snakemake.input.surrogate,
    folder=snakemake.params.folder,
    m_eff_surrogate_path=next(iter(snakemake.input.m_eff_surrogate), None),
)
