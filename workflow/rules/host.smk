# The host-coupled check of the C_eq model (not part of `all`): a single-degree-of-freedom host
# carrying the design's filled cells (config host), forced around its resonance, (a) coupled to
# the compiled DEM, (b) with the surrogate's C_eq as a dashpot and (c) with the damper's m_eff
# and C_eq (when there is an m_eff surrogate); their curves compared.
#   snakemake --cores 2 host
# One job pours the host's k packings (results/work/host/packings, reused) and runs every force
# level x frequency, two at a time with --cores 2.

rule check_host:
    input:
        surrogate="results/surrogate.json",
        designs="results/optimum.json",
        m_eff_surrogate=get_m_eff_surrogate(),
    output:
        curves=report("results/host/curves.csv", caption="../report/host.rst", category="9. Host"),
        summary=report("results/host/summary.csv", caption="../report/host.rst",
                       category="9. Host"),
        meta="results/host/host.json",
    params:
        config=get_host_config(),
        folder="results/work/host/packings",
    log:
        "logs/check_host.log",
    benchmark:
        "results/benchmarks/check_host.tsv"
    threads: 2
    script:
        "../scripts/check_host.py"


rule plot_host:
    input:
        curves="results/host/curves.csv",
    output:
        png=report("results/host/host.png", caption="../report/host.rst", category="9. Host"),
    log:
        "logs/plot_host.log",
    script:
        "../scripts/plot_host.py"


rule host:
    input:
        "results/host/curves.csv",
        "results/host/summary.csv",
        "results/host/host.json",
        "results/host/host.png",
