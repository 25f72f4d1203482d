"""Rule plot_fidelity: error in C_eq against CPU time (pidpipe.fidelity_study.plot_fidelity_study)."""

from pidpipe.campaign import run_step
from pidpipe.fidelity_study import plot_fidelity_study

run_step(
    plot_fidelity_study,
    snakemake.log[0],
    table_path=snakemake.input.table,
    summary_path=snakemake.input.summary,
    error_target=snakemake.params.error_target,
    png=snakemake.output.png,
)
