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
        packing_pool="results/packings/pool",
        movie=get_case_movie,
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


# engine: dem only (DEM_BATCH_FREQ matches nothing with LIGGGHTS): the cases of every fill at one
# frequency, acceleration and replicate in one job, each with its own record and log, the same
# record as simulate_case writes; the job's start-up (~1.2 s CPU) is paid once for all of them.
ruleorder: simulate_dem_cases > simulate_case


rule simulate_dem_cases:
    input:
        packings=get_dem_batch_packings,
        checked=ancient("results/packings/check.tsv"),
    output:
        records=expand("results/cases/f{{freq}}Hz_G{{accel}}_r{fill}pct_rep{{replicate}}.json",
                       fill=DEM_BATCH_FILLS),
    wildcard_constraints:
        freq=DEM_BATCH_FREQ,
    params:
        config=get_case_config(),
        case_ids=get_dem_batch_case_ids,
        packings=get_dem_batch_packings_by_case,
        workdirs=get_dem_batch_workdirs,
        packing_pool="results/packings/pool",
        movies=get_dem_batch_movies,
    log:
        cases=expand("logs/simulate_case/f{{freq}}Hz_G{{accel}}_r{fill}pct_rep{{replicate}}.log",
                     fill=DEM_BATCH_FILLS),
        job="logs/simulate_dem_cases/f{freq}Hz_G{accel}_rep{replicate}.log",
    benchmark:
        "results/benchmarks/simulate_dem_cases/f{freq}Hz_G{accel}_rep{replicate}.tsv"
    threads: 1
    priority: get_dem_batch_priority
    resources:
        runtime=get_dem_batch_runtime_min,
    script:
        "../scripts/simulate_dem_cases.py"
