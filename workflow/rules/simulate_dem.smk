# engine: dem: the cases of every grid fill at one frequency, acceleration and replicate in one
# job, each with its own record and log, the same record as simulate_case writes in LIGGGHTS;
# the job's start-up (~1.2 s CPU) is paid once for all of them.


rule simulate_dem_cases:
    input:
        packings=get_dem_batch_packings,
        checked=ancient("results/packings/check.tsv"),
    output:
        records=expand("results/cases/" + CASE_PATTERN + ".json", fill=DEM_BATCH_FILLS,
                       allow_missing=True),
    params:
        config=get_case_config,
        case_ids=get_dem_batch_case_ids,
        packings=get_dem_batch_packings_by_case,
        workdirs=get_dem_batch_workdirs,
        packing_pool="results/packings/pool",
        movies=get_dem_batch_movies,
    log:
        cases=expand("logs/simulate_case/" + CASE_PATTERN + ".log", fill=DEM_BATCH_FILLS,
                     allow_missing=True),
        job="logs/simulate_dem_cases/f{freq}Hz_G{accel}_rep{replicate}.log",
    benchmark:
        "results/benchmarks/simulate_dem_cases/f{freq}Hz_G{accel}_rep{replicate}.tsv"
    threads: 1
    priority: get_dem_batch_priority
    resources:
        runtime=get_dem_batch_runtime_min,
    script:
        "../scripts/simulate_dem_cases.py"
