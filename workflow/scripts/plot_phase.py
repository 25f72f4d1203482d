"""Rule plot_phase: one case's phase-resolved figure (pidpipe.steps.figures.plot_case_phase)."""

from pidpipe.steps.figures import plot_case_phase
from pidpipe.steps.run import run_step

run_step(
    plot_case_phase,
    snakemake.log[0],
    record_path=snakemake.input.record,
    png=snakemake.output.png,
)
