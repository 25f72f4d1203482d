# Stage 3: the C_eq table, one row per grid point (replicates averaged), failed cases marked.


rule collect_table:
    input:
        records=get_case_records(),
    output:
        table=report(
            "results/ceq_table.csv",
            caption="../report/ceq_table.rst",
            category="1. DEM campaign",
        ),
    params:
        case_ids=get_case_ids(),
        full_cell_spheres=get_full_cell_spheres(),
    log:
        "logs/collect_table.log",
    script:
        "../scripts/collect_table.py"


rule table:
    input:
        "results/ceq_table.csv",
