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
