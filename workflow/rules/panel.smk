# The panel's modal stage (not part of `all`): the config's simply supported sandwich plate, its
# modes with the core's transverse shear, and on each mode in an environment's band the
# source-style and the optimised layouts of the particles with their added loss factors; the modal
# mass takes the particles' m_eff from results/surrogate_m_eff.json when the table has m_eff.
#   snakemake --cores 2 panel
# It refits the surrogate's bootstrap draws and reruns the coupon designs: about a minute.


rule design_panel:
    input:
        surrogate="results/surrogate.json",
        m_eff_surrogate=get_m_eff_surrogate(),
    output:
        modes="results/panel/modes.csv",
        layout="results/panel/layout.csv",
        designs=report("results/panel/designs.csv", caption="../report/panel.rst",
                       category="10. Panel"),
        response="results/panel/response.csv",
        png=report("results/panel/panel.png", caption="../report/panel.rst", category="10. Panel"),
        pdf="results/panel/panel.pdf",
    params:
        config=get_panel_config(),
        folder="results/panel",
    log:
        "logs/design_panel.log",
    benchmark:
        "results/benchmarks/design_panel.tsv"
    script:
        "../scripts/design_panel.py"


rule panel:
    input:
        rules.design_panel.output,


# The DEM check of a mode (not part of `all`): the mode of panel.check's environment as a host
# carrying compiled-DEM cells of the checked layout in groups along the mode shape, coupled two
# ways and swept in frequency at one modal force, against the panel model (pidpipe.panel.check).
#   snakemake --cores 2 panel_check
# It pours groups x cells_per_group packings (results/work/panel/packings, reused) and runs
# freq_points coupled runs, two at a time with --cores 2.

rule check_panel_mode:
    input:
        surrogate="results/surrogate.json",
        m_eff_surrogate=get_m_eff_surrogate(),
        layout="results/panel/layout.csv",
    output:
        curves=report("results/panel/check/curves.csv", caption="../report/panel_check.rst",
                      category="10. Panel"),
        summary=report("results/panel/check/summary.csv", caption="../report/panel_check.rst",
                       category="10. Panel"),
        meta="results/panel/check/check.json",
    params:
        config=get_panel_check_config(),
        folder="results/work/panel/packings",
    log:
        "logs/check_panel_mode.log",
    benchmark:
        "results/benchmarks/check_panel_mode.tsv"
    threads: 2
    script:
        "../scripts/check_panel_mode.py"


rule panel_check:
    input:
        rules.check_panel_mode.output,
