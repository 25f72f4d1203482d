# Stage 3b (refine.enabled): the design-driven refinement loop after the grid's pilots
# (pidpipe.refine). Each step is a checkpoint: it asks the loop again from its saved table with
# an engine that runs nothing, and writes which runs the loop lacks (or that it stopped); each
# run is a job of its own (up to --cores at a time); the next step continues. With
# refine.run_cases in_step (auto: the compiled DEM) the step runs the cases itself, on its
# threads, round after round: one step is the whole loop. The designs then
# rest on the table the loop's last round fitted (results/ceq_table_refined.csv).
#   snakemake --cores 2 refine


checkpoint refine_step:
    input:
        unpack(get_refine_step_inputs),
    output:
        step="results/refine/steps/{step}.json",
    params:
        depends=get_refine_params(),
        refine_dir="results/refine",
    log:
        "logs/refine/step{step}.log",
    benchmark:
        "results/benchmarks/refine/step{step}.tsv"
    threads: get_refine_step_threads
    resources:
        runtime=get_refine_step_runtime_min,
    script:
        "../scripts/refine_step.py"


rule run_refine_case:
    output:
        record="results/refine/work/cases/{run}.json",
    params:
        depends=get_refine_params(),
        refine_dir="results/refine",
    log:
        "logs/refine/cases/{run}.log",
    benchmark:
        "results/benchmarks/refine/cases/{run}.tsv"
    threads: 1
    resources:
        runtime=get_refine_run_runtime_min,
    script:
        "../scripts/run_refine_case.py"


rule finish_refine:
    input:
        last_step=get_refine_last_step,
    output:
        table=report("results/ceq_table_refined.csv", caption="../report/refine_table.rst",
                     category="11. Refinement"),
        rounds=report("results/refine/rounds.csv", caption="../report/refine.rst",
                      category="11. Refinement"),
        summary="results/refine/summary.json",
        verify_points="results/refine/verify_points.csv",
        png=report("results/refine/convergence.png", caption="../report/refine.rst",
                   category="11. Refinement"),
        pdf="results/refine/convergence.pdf",
    params:
        refine_dir="results/refine",
    log:
        "logs/finish_refine.log",
    script:
        "../scripts/finish_refine.py"


rule refine:
    input:
        "results/ceq_table_refined.csv",
        "results/refine/rounds.csv",
        "results/refine/convergence.png",
