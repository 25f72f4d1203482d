# Validation (not part of `all`): chosen single-cell cases in LIGGGHTS and in the NumPy DEM.
#   snakemake --cores 2 validate


rule validate:
    input:
        packings=get_validation_packings(),
        checked=ancient("results/packings/check.tsv"),
    output:
        table=report("results/validation/validation.csv", caption="../report/validation.rst",
                     category="4. Validation"),
        plot=report("results/validation/validation.png", caption="../report/validation.rst",
                    category="4. Validation"),
    params:
        config=get_case_config(),
        cases=get_validation_cases(),
        workdir="results/work/validation",
    log:
        "logs/validate.log",
    benchmark:
        "results/benchmarks/validate.tsv"
    script:
        "../scripts/validate_against_dem.py"
