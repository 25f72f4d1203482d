"""Rule simulate_dem_cases: the DEM's cases of one frequency, acceleration and replicate, one
after another in one process (pidpipe.steps.cases.simulate_cases)."""

from pidpipe.steps.cases import simulate_cases
from pidpipe.steps.run import run_step

run_step(
    simulate_cases,
    snakemake.log.job,
    config=snakemake.params.config,
    case_ids=list(snakemake.params.case_ids),
    packing_paths=[list(paths) for paths in snakemake.params.packings],
    record_paths=list(snakemake.output.records),
    workdirs=list(snakemake.params.workdirs),
    log_paths=list(snakemake.log.cases),
    packing_pool=snakemake.params.packing_pool,
    movies=list(snakemake.params.movies),
)
