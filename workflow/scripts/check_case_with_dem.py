"""Rule validate_case: one campaign case in the compiled DEM (pidpipe.steps.validate.check_case_with_dem)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.validate import check_case_with_dem

run_step(
    check_case_with_dem,
    snakemake.log[0],
    config=snakemake.params.config,
    liggghts_record_path=snakemake.input.record,
    packing_paths=list(snakemake.input.packings),
    record_path=snakemake.output.record,
    packing_pool=snakemake.params.packing_pool,
)
