"""Rule plan_verify: the designs' verifying cases (pidpipe.steps.verify.plan_verify)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.verify import plan_verify

run_step(
    plan_verify,
    snakemake.log[0],
    optimum_path=snakemake.input.optimum,
    fill=snakemake.params.fill,
    points_path=snakemake.output.points,
)
