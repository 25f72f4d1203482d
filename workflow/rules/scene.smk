# The scene study (not part of `all`): one cell x N against replicate cells shaken alone,
# patches of 7 and 19 cells and the whole coupon in one LIGGGHTS run each, with the same
# replicate packings (cell i = the i-th replicate the packing check accepts); C_eq per cell with its standard errors and the
# CPU time of each scene (config: scene).
#   snakemake --cores 2 scene
# One job runs every scene in turn (CPU times are measured one run at a time); it pours its
# packings (two at a time with --cores 2) into results/work/scene/packings and reuses them.


rule run_scene_study:
    output:
        table=report("results/scene/scene.csv", caption="../report/scene.rst",
                     category="8. Scene"),
        comparisons=report("results/scene/scene_comparisons.csv",
                           caption="../report/scene_comparisons.rst", category="8. Scene"),
    params:
        config=get_scene_config(),
        folder="results/work/scene",
    log:
        "logs/run_scene_study.log",
    benchmark:
        "results/benchmarks/run_scene_study.tsv"
    threads: 2
    script:
        "../scripts/run_scene_study.py"


rule plot_scene:
    input:
        table="results/scene/scene.csv",
    output:
        png=report("results/scene/scene.png", caption="../report/scene.rst", category="8. Scene"),
    log:
        "logs/plot_scene.log",
    script:
        "../scripts/plot_scene.py"


rule scene:
    input:
        "results/scene/scene.csv",
        "results/scene/scene_comparisons.csv",
        "results/scene/scene.png",
