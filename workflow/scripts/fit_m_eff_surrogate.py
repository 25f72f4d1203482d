"""Rule fit_m_eff_surrogate: the m_eff Gaussian process (pidpipe.steps.design.fit_m_eff_surrogate)."""

from pidpipe.steps.design import fit_m_eff_surrogate
from pidpipe.steps.run import run_step

run_step(
    fit_m_eff_surrogate,
    snakemake.log[0],
    table_path=snakemake.input.table,
    allow_holes=snakemake.params.allow_holes,
    surrogate_path=snakemake.output.surrogate,
)
