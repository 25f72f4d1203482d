# Close the loop (not part of `all`).
#   snakemake --cores 2 verify   every environment's band_mean and peak design shaken by DEM
#                                (verify.engine) at its fill, at its band's four corners and
#                                centre, to the campaign's target, and compared with the
#                                surrogates (C_eq, and m_eff with the campaign's table):
#                                results/verify.csv and results/verify.png
# The cases follow from the designs, so plan_verify is a checkpoint; a point two designs share
# is one case. Each is replicate 100 of its point (pidpipe.loop.verify.VERIFY_REPLICATE): its
# packings, poured and checked in results/verify/packings/, are none the campaign shakes.
# No ancient()/update() here: with them Snakemake 9.27 dropped the verify job in a run whose
# checkpoint changed the plan.


checkpoint plan_verify:
    input:
        optimum="results/optimum.json",
    output:
        points="results/verify/points.csv",
    params:
        fill=get_fill_config(),
    log:
        "logs/verify/plan_verify.log",
    script:
        "../scripts/plan_verify.py"


rule pour_verify_packing:
    output:
        "results/verify/packings/" + PACKING_PATTERN + ".json",
    params:
        config=get_packing_config(),
        workdir="results/work/verify/packings/" + PACKING_PATTERN,
    log:
        "logs/verify/pour_packing/" + PACKING_PATTERN + ".log",
    benchmark:
        "results/benchmarks/verify/pour_packing/" + PACKING_PATTERN + ".tsv"
    threads: 1
    script:
        "../scripts/pour_packing.py"


# Each packing is checked on its own (as check_packings checks the campaign's), so that a
# new plan adds checks for its new packings and leaves the cases already shaken alone.
rule check_verify_packing:
    input:
        "results/verify/packings/" + PACKING_PATTERN + ".json",
    output:
        "results/verify/packings/" + PACKING_PATTERN + ".check.tsv",
    log:
        "logs/verify/check_packing/" + PACKING_PATTERN + ".log",
    script:
        "../scripts/check_verify_packing.py"


rule simulate_verify_case:
    input:
        packings=get_verify_case_packings,
        checked=get_verify_case_packing_checks,
    output:
        record="results/verify/cases/" + CASE_PATTERN + ".json",
    params:
        config=get_verify_case_config(),
        case_id=get_case_id,
        workdir="results/work/verify/cases/" + CASE_PATTERN,
        packing_pool="results/verify/packings/pool",
        movie={},
    log:
        "logs/verify/simulate_case/" + CASE_PATTERN + ".log",
    benchmark:
        "results/benchmarks/verify/simulate_case/" + CASE_PATTERN + ".tsv"
    threads: 1
    resources:
        runtime=get_verify_case_runtime_min,
    script:
        "../scripts/simulate_case.py"


rule compare_designs:
    input:
        points="results/verify/points.csv",
        records=get_verify_records,
        surrogate="results/surrogate.json",
        m_eff_surrogate=get_m_eff_surrogate(),
    output:
        table=report("results/verify.csv", caption="../report/verify.rst",
                     category="6. Verification"),
        plot=report("results/verify.png", caption="../report/verify.rst",
                    category="6. Verification"),
    params:
        verify=get_verify_params(),
        case_config=get_verify_case_config(),
    log:
        "logs/verify/verify.log",
    script:
        "../scripts/compare_designs.py"


rule verify:
    input:
        "results/verify.csv",
        "results/verify.png",
