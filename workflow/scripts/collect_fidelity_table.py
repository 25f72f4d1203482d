"""Rule collect_fidelity_table: the study's table and summary (pidpipe.studies.fidelity.collect_fidelity_study)."""

from pidpipe.steps.run import run_step
from pidpipe.studies.fidelity import collect_fidelity_study

run_step(
    collect_fidelity_study,
    snakemake.log[0],
    record_paths=list(snakemake.input.records),
    jobs=list(snakemake.params.jobs),
    variants=list(snakemake.params.variants),
    baseline=snakemake.params.baseline,
    error_target=snakemake.params.error_target,
    table_path=snakemake.output.table,
    summary_path=snakemake.output.summary,
)
