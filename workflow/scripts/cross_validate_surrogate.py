"""Rule cross_validate_surrogate: leave-one-out errors (pidpipe.campaign.cross_validate_table)."""

from pidpipe.campaign import cross_validate_table, run_step

run_step(
    cross_validate_table,
    snakemake.log[0],
    table_path=snakemake.input.table,
    cv_path=snakemake.output.cv,
)
