# Stage 2: shake one case (frequency x acceleration x fill x replicate) with the configured
# engine: LIGGGHTS (the default) or the compiled in-repo DEM (engine: dem), on the same pour.


rule simulate_case:
    input:
        packings=get_case_packings,
        checked=ancient("results/packings/check.tsv"),
    output:
        record="results/cases/f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}.json",
    params:
        config=get_case_config(),
        case_id=get_case_id,
        workdir="results/work/cases/f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}",
    log:
        "logs/simulate_case/f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}.log",
    benchmark:
        "results/benchmarks/simulate_case/f{freq}Hz_G{accel}_r{fill}pct_rep{replicate}.tsv"
    threads: 1
    resources:
        runtime=get_case_runtime_min,
    script:
        "../scripts/simulate_case.py"


rule cases:
    input:
        get_case_records(),
