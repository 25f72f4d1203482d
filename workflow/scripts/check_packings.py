"""Rule check_packings: refuse every packing that does not fit (pidpipe.steps.packings.check_packings)."""

from pidpipe.steps.packings import check_packings
from pidpipe.steps.run import run_step

run_step(
    check_packings,
    snakemake.log[0],
    packing_paths=list(snakemake.input.packings),
    case_ids=list(snakemake.params.case_ids),
    report_path=snakemake.output[0],
    cells_per_run=snakemake.params.cells_per_run,
)
