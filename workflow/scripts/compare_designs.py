"""Rule verify: each verifying case against the surrogate (pidpipe.steps.verify.compare_designs)."""

from pidpipe.steps.run import run_step
from pidpipe.steps.verify import compare_designs

run_step(
    compare_designs,
    snakemake.log[0],
    points_path=snakemake.input.points,
    record_paths=list(snakemake.input.records),
    surrogate_path=snakemake.input.surrogate,
    verify=snakemake.params.verify,
    case_config=snakemake.params.case_config,
    table_path=snakemake.output.table,
    plot_path=snakemake.output.plot,
    m_eff_surrogate_path=next(iter(snakemake.input.m_eff_surrogate), None),
)
