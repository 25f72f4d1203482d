"""Rule run_refine_case: one run the refinement loop asked for
(pidpipe.steps.refine.run_refine_plan)."""

from pidpipe.steps.refine import run_refine_plan
from pidpipe.steps.run import run_step

run_step(
    run_refine_plan,
    snakemake.log[0],
    config=dict(snakemake.config),
    refine_dir=snakemake.params.refine_dir,
    case_id=snakemake.wildcards.run,
)
