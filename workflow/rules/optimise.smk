# Stage 5: multi-start SLSQP of fill and filled cells per operating environment: the peak,
# band_mean and worst_case designs, and their parametric bootstrap.


rule optimise_environments:
    input:
        surrogate="results/surrogate.json",
        cv="results/surrogate_cv.csv",  # the surrogate's leave-one-out error, computed once
    output:
        results=report(
            "results/optimum.csv",
            caption="../report/optimum.rst",
            category="3. Optimisation",
        ),
        history="results/optimum_history.csv",
        json="results/optimum.json",
        bootstrap="results/optimum_bootstrap.csv",
    params:
        environments=get_environments(),
        budget=get_budget(),
        optimisation=get_optimisation_params(),
    log:
        "logs/optimise_environments.log",
    benchmark:
        "results/benchmarks/optimise_environments.tsv"
    threads: 2  # the bootstrap's draws in two processes: the stage the campaign's end waits for
    priority: 2  # before the surrogate's figures, which nothing waits for
    script:
        "../scripts/optimise_environments.py"


rule optimum:
    input:
        "results/optimum.csv",
