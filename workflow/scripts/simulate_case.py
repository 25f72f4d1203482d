"""Rule simulate_case: shake one case with the configured engine (pidpipe.steps.cases.simulate_case)."""

from pidpipe.steps.cases import simulate_case
from pidpipe.steps.run import run_step

run_step(
    simulate_case,
    snakemake.log[0],
    config=snakemake.params.config,
    case_id=snakemake.params.case_id,
    packing_paths=list(snakemake.input.packings),
    record_path=snakemake.output.record,
    workdir=snakemake.params.workdir,
    log_path=snakemake.log[0],
)
