# The fidelity study (not part of `all`): every fidelity_study case shaken at the reference
# setting and at each variant, on the campaign's replicate-0 packing of its fill; then the
# table of errors in C_eq against CPU time, the summary per variant and the figure.
#   snakemake --cores 2 fidelity
#   snakemake --report report.html all fidelity   # the report with the study in it
# Each (case, setting) is one job, the costliest first (priority = planned time steps), so both
# cores stay busy to the end. A changed reference or variant reruns only its own jobs.

rule simulate_fidelity_case:
    input:
        packing="results/packings/" + PACKING_PATTERN + ".json",
    output:
        record="results/fidelity/cases/{variant}/" + CASE_PATTERN + ".json",
    params:
        config=get_fidelity_case_config,
        case_id=get_case_id,
        workdir="results/work/fidelity/{variant}/" + CASE_PATTERN,
    wildcard_constraints:
        variant=r"[A-Za-z][A-Za-z0-9_]*",
    log:
        "logs/simulate_fidelity_case/{variant}/" + CASE_PATTERN + ".log",
    benchmark:
        "results/benchmarks/simulate_fidelity_case/{variant}/" + CASE_PATTERN + ".tsv"
    priority: get_fidelity_priority
    threads: 1
    script:
        "../scripts/simulate_case.py"


rule collect_fidelity_table:
    input:
        records=get_fidelity_records(),
    output:
        table=report("results/fidelity/fidelity.csv", caption="../report/fidelity_table.rst",
                     category="7. Fidelity study"),
        summary=report("results/fidelity/fidelity_summary.csv",
                       caption="../report/fidelity_summary.rst", category="7. Fidelity study"),
    params:
        jobs=get_fidelity_jobs(),
        variants=get_fidelity_variants(),
        baseline=FIDELITY_STUDY.baseline,
        error_target=FIDELITY_STUDY.error_target,
    log:
        "logs/collect_fidelity_table.log",
    script:
        "../scripts/collect_fidelity_table.py"


rule plot_fidelity:
    input:
        table="results/fidelity/fidelity.csv",
        summary="results/fidelity/fidelity_summary.csv",
    output:
        png=report("results/fidelity/fidelity.png", caption="../report/fidelity.rst",
                   category="7. Fidelity study"),
        pdf="results/fidelity/fidelity.pdf",
    params:
        error_target=FIDELITY_STUDY.error_target,
    log:
        "logs/plot_fidelity.log",
    script:
        "../scripts/plot_fidelity.py"


rule fidelity:
    input:
        rules.collect_fidelity_table.output,
        rules.plot_fidelity.output,
