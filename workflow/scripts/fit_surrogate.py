"""Rule fit_surrogate: fit and save the surrogate (pidpipe.steps.design.fit_table_surrogate)."""

from pidpipe.steps.design import fit_table_surrogate
from pidpipe.steps.run import run_step

run_step(
    fit_table_surrogate,
    snakemake.log[0],
    table_path=snakemake.input.table,
    method=snakemake.params.method,
    allow_holes=snakemake.params.allow_holes,
    surrogate_path=snakemake.output.surrogate,
)
