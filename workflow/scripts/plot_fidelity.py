"""Rule plot_fidelity: error in C_eq against CPU time (pidpipe.studies.fidelity.plot_fidelity_study)."""

from pidpipe.steps.run import run_step
from pidpipe.studies.fidelity import plot_fidelity_study

run_step(
    plot_fidelity_study,
    snakemake.log[0],
    table_path=snakemake.input.table,
    summary_path=snakemake.input.summary,
    error_target=snakemake.params.error_target,
    png=snakemake.output.png,
)
