# Stage 4: the surrogate of C_eq(f, G, r) and the cross-validation of every method, and the
# Gaussian process of one cell's effective mass m_eff(f, G, r) (pidpipe damper, host model (c)).
# The table is optimisation.external_ceq_table when set, else the campaign's.


rule fit_surrogate:
    input:
        table=get_ceq_table(),
    output:
        surrogate="results/surrogate.json",
    params:
        method=get_surrogate_method(),
        allow_holes=get_surrogate_allow_holes(),
    log:
        "logs/fit_surrogate.log",
    priority: 3  # first of the designs' path: fit, cross-validate, optimise, then the figures
    script:
        "../scripts/fit_surrogate.py"


rule fit_m_eff_surrogate:
    input:
        table=get_ceq_table(),
    output:
        surrogate="results/surrogate_m_eff.json",
    params:
        allow_holes=get_surrogate_allow_holes(),
    log:
        "logs/fit_m_eff_surrogate.log",
    script:
        "../scripts/fit_m_eff_surrogate.py"


rule cross_validate_surrogate:
    input:
        table=get_ceq_table(),
    output:
        cv=report(
            "results/surrogate_cv.csv",
            caption="../report/surrogate_cv.rst",
            category="2. Surrogate",
        ),
    log:
        "logs/cross_validate_surrogate.log",
    benchmark:
        "results/benchmarks/cross_validate_surrogate.tsv"
    threads: 2  # the folds in two processes (a GP refitted per fold: a minute on one core)
    priority: 2  # before the surrogate's figures: the designs wait for it
    script:
        "../scripts/cross_validate_surrogate.py"


rule surrogate:
    input:
        "results/surrogate.json",
        "results/surrogate_cv.csv",
        get_m_eff_surrogate(),
