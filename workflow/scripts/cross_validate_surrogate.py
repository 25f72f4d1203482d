"""Rule cross_validate_surrogate: leave-one-out errors (pidpipe.steps.design.cross_validate_table)."""

from pidpipe.steps.design import cross_validate_table
from pidpipe.steps.run import run_step

run_step(
    cross_validate_table,
    snakemake.log[0],
    table_path=snakemake.input.table,
    cv_path=snakemake.output.cv,
)
