"""Rule check_verify_packing: refuse a verifying packing that does not fit (pidpipe.steps.verify.check_verify_packing)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.verify import check_verify_packing

run_step(
    check_verify_packing,
    snakemake.log[0],
    packing_path=snakemake.input[0],
    report_path=snakemake.output[0],
)
