# Stage 1: pour and settle one packing per fill level and replicate (fidelity.pour_engine), then
# check them all. pour_packing pours one packing a job with either engine; with the DEM pour the
# Snakefile also includes pour_dem.smk, which pours each grid fill's packings in one job.


rule pour_packing:
    output:
        "results/packings/" + PACKING_PATTERN + ".json",
    params:
        config=get_packing_config(),
        workdir="results/work/packings/" + PACKING_PATTERN,
    log:
        "logs/pour_packing/" + PACKING_PATTERN + ".log",
    benchmark:
        "results/benchmarks/pour_packing/" + PACKING_PATTERN + ".tsv"
    threads: 1
    script:
        "../scripts/pour_packing.py"


# Every packing must fit under the lid before any case is shaken; misfits are listed together.
# update(): a failed check keeps the previous report, and cases take it as ancient(), so adding
# a fill level (or a failed check) never reruns the cases already finished.
rule check_packings:
    input:
        packings=get_packings(),
    output:
        report(
            update("results/packings/check.tsv"),
            caption="../report/packings.rst",
            category="1. DEM campaign",
        ),
    params:
        case_ids=get_case_ids(),
        cells_per_run=get_cells_per_run(),
    log:
        "logs/check_packings.log",
    script:
        "../scripts/check_packings.py"


rule packings:
    input:
        "results/packings/check.tsv",
