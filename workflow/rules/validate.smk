# Validation (not part of `all`).
#   snakemake --cores 2 validate          every case of the campaign checked by the compiled
#                                         DEM on the campaign's own packings, against the
#                                         LIGGGHTS records: results/validation/grid.csv and
#                                         grid.png (parity)
#   snakemake --cores 2 validate_chosen   validation.cases run afresh in LIGGGHTS and the DEM


rule validate_case:
    input:
        record="results/cases/" + CASE_PATTERN + ".json",
        packings=get_case_packings,
        checked=ancient("results/packings/check.tsv"),
    output:
        record="results/validation/dem/" + CASE_PATTERN + ".json",
    params:
        config=get_case_config,
        packing_pool="results/packings/pool",
    log:
        "logs/validate_case/" + CASE_PATTERN + ".log",
    benchmark:
        "results/benchmarks/validate_case/" + CASE_PATTERN + ".tsv"
    threads: 1
    script:
        "../scripts/check_case_with_dem.py"


rule collect_grid_check:
    input:
        liggghts=get_case_records(),
        dem=get_dem_check_records(),
    output:
        table=report("results/validation/grid.csv", caption="../report/grid_check.rst",
                     category="5. Validation"),
        plot=report("results/validation/grid.png", caption="../report/grid_check.rst",
                    category="5. Validation"),
    log:
        "logs/validate.log",
    script:
        "../scripts/collect_grid_check.py"


rule validate_against_dem:
    input:
        packings=get_validation_packings(),
        checked=ancient("results/packings/check.tsv"),
    output:
        table=report("results/validation/validation.csv", caption="../report/validation.rst",
                     category="5. Validation"),
        plot=report("results/validation/validation.png", caption="../report/validation.rst",
                    category="5. Validation"),
    params:
        config=get_fresh_case_config(),
        cases=get_validation_cases(),
        workdir="results/work/validation",
    log:
        "logs/validate_chosen.log",
    benchmark:
        "results/benchmarks/validate_chosen.tsv"
    script:
        "../scripts/validate_against_dem.py"


rule validate:
    input:
        "results/validation/grid.csv",
        "results/validation/grid.png",


rule validate_chosen:
    input:
        "results/validation/validation.csv",
        "results/validation/validation.png",
