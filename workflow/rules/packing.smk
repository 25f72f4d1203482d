# Stage 1: pour and settle one packing per fill level and replicate (fidelity.pour_engine), then check them all.
# With the DEM pour the packings of one fill are one job (pour_dem_packings), with LIGGGHTS one job each.


rule pour_packing:
    output:
        "results/packings/r{fill}pct_rep{replicate}.json",
    params:
        config=get_packing_config(),
        workdir="results/work/packings/r{fill}pct_rep{replicate}",
    log:
        "logs/pour_packing/r{fill}pct_rep{replicate}.log",
    benchmark:
        "results/benchmarks/pour_packing/r{fill}pct_rep{replicate}.tsv"
    threads: 1
    script:
        "../scripts/pour_packing.py"


# fidelity.pour_engine: dem only (POUR_BATCH_FILL matches nothing with LIGGGHTS): every packing
# of one grid fill that the cases shake, poured in one job as one batch, each the packing that
# pour_packing pours alone; outputs one file per packing, as pour_packing's.
ruleorder: pour_dem_packings > pour_packing


rule pour_dem_packings:
    output:
        packings=expand("results/packings/r{{fill}}pct_rep{replicate}.json",
                        replicate=POUR_BATCH_REPLICATES),
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
