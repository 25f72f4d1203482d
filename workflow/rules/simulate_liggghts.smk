# engine: liggghts (the default): shake one case per job in LIGGGHTS (its start-up is small
# beside its runs; a job per case keeps them parallel).


rule simulate_case:
    input:
        packings=get_case_packings,
        checked=ancient("results/packings/check.tsv"),
    output:
        record="results/cases/" + CASE_PATTERN + ".json",
    params:
        config=get_case_config,
        case_id=get_case_id,
        workdir="results/work/cases/" + CASE_PATTERN,
        packing_pool="results/packings/pool",
        movie=get_case_movie,
    log:
        "logs/simulate_case/" + CASE_PATTERN + ".log",
    benchmark:
        "results/benchmarks/simulate_case/" + CASE_PATTERN + ".tsv"
    threads: 1
    resources:
        runtime=get_case_runtime_min,
    script:
        "../scripts/simulate_case.py"
