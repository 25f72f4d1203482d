"""Rule collect_table: the C_eq table from the case records (pidpipe.steps.table.collect_table)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.table import collect_table

run_step(
    collect_table,
    snakemake.log[0],
    record_paths=list(snakemake.input.records),
    table_path=snakemake.output.table,
    case_ids=list(snakemake.params.case_ids),
    full_cell_spheres=int(snakemake.params.full_cell_spheres),
)
