# fidelity.pour_engine: dem: every packing of one grid fill that the cases shake, poured in one
# job as one batch (one process's start-up), each the packing that pour_packing pours alone;
# one output file per packing, as pour_packing's. Fills outside the grid (validation.cases,
# fidelity_study) are still poured by pour_packing, one a job; for the grid's this rule wins.
ruleorder: pour_dem_packings > pour_packing


rule pour_dem_packings:
    output:
        packings=expand("results/packings/" + PACKING_PATTERN + ".json",
                        replicate=POUR_BATCH_REPLICATES, allow_missing=True),
    wildcard_constraints:
        fill=POUR_BATCH_FILL,
    params:
        config=get_packing_config(),
        replicates=POUR_BATCH_REPLICATES,
        workdirs=get_pour_batch_workdirs,
    log:
        "logs/pour_dem_packings/r{fill}pct.log",
    benchmark:
        "results/benchmarks/pour_dem_packings/r{fill}pct.tsv"
    threads: 1
    script:
        "../scripts/pour_dem_packings.py"
