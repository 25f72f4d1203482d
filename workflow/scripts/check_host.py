"""Rule check_host: the host-coupled check of one design (pidpipe.steps.host.check_host)."""

from pidpipe.steps.host import check_host
from pidpipe.steps.run import run_step

run_step(
    check_host,
    snakemake.log[0],
    config=snakemake.params.config,
    surrogate_path=snakemake.input.surrogate,
    designs_path=snakemake.input.designs,
    curves_path=snakemake.output.curves,
    summary_path=snakemake.output.summary,
    meta_path=snakemake.output.meta,
    folder=snakemake.params.folder,
    workers=snakemake.threads,
    m_eff_surrogate_path=next(iter(snakemake.input.m_eff_surrogate), None),
)
