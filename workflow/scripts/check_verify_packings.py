"""Rule check_verify_packings: refuse every verifying packing that does not fit (pidpipe.steps.verify.check_verify_packings)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.verify import check_verify_packings

run_step(
    check_verify_packings,
    snakemake.log[0],
    points_path=snakemake.input.points,
    packing_paths=list(snakemake.input.packings),
    report_path=snakemake.output[0],
    cells_per_run=snakemake.params.cells_per_run,
)
