# Stage 6: figures of the surrogates (C_eq with its bootstrap spread, m_eff with its predictive
# uncertainty) and of the optimisation (PNG for the report, and PDF).


rule plot_surrogate:
    input:
        surrogate="results/surrogate.json",
    output:
        freq_fill=report(
            "results/figures/ceq_freq_fill.png",
            caption="../report/ceq_freq_fill.rst",
            category="2. Surrogate",
        ),
        freq_fill_pdf="results/figures/ceq_freq_fill.pdf",
        freq_accel=report(
            "results/figures/ceq_freq_accel.png",
            caption="../report/ceq_freq_accel.rst",
            category="2. Surrogate",
        ),
        freq_accel_pdf="results/figures/ceq_freq_accel.pdf",
    params:
        uncertainty=get_map_uncertainty_params(),
    log:
        "logs/plot_surrogate.log",
    script:
        "../scripts/plot_surrogate.py"


# The m_eff maps beside the C_eq maps: m_eff / bed mass from the m_eff surrogate over its
# predictive standard uncertainty; the table gives each fill's bed mass.
rule plot_m_eff_surrogate:
    input:
        surrogate="results/surrogate_m_eff.json",
        table=get_ceq_table(),
    output:
        freq_fill=report(
            "results/figures/m_eff_freq_fill.png",
            caption="../report/m_eff_freq_fill.rst",
            category="2. Surrogate",
        ),
        freq_fill_pdf="results/figures/m_eff_freq_fill.pdf",
        freq_accel=report(
            "results/figures/m_eff_freq_accel.png",
            caption="../report/m_eff_freq_accel.rst",
            category="2. Surrogate",
        ),
        freq_accel_pdf="results/figures/m_eff_freq_accel.pdf",
    log:
        "logs/plot_m_eff_surrogate.log",
    script:
        "../scripts/plot_m_eff_surrogate.py"


rule plot_convergence:
    input:
        results="results/optimum.json",
    output:
        png=report(
            "results/figures/convergence.png",
            caption="../report/convergence.rst",
            category="3. Optimisation",
        ),
        pdf="results/figures/convergence.pdf",
    log:
        "logs/plot_convergence.log",
    script:
        "../scripts/plot_convergence.py"


rule plot_optimum_spread:
    input:
        results="results/optimum.json",
        bootstrap="results/optimum_bootstrap.csv",
    output:
        png=report(
            "results/figures/optimum_spread.png",
            caption="../report/optimum_spread.rst",
            category="3. Optimisation",
        ),
        pdf="results/figures/optimum_spread.pdf",
    log:
        "logs/plot_optimum_spread.log",
    script:
        "../scripts/plot_optimum_spread.py"


rule plot_phase:
    input:
        record="results/cases/" + CASE_PATTERN + ".json",
    output:
        png=report(
            "results/figures/phase/" + CASE_PATTERN + ".png",
            caption="../report/phase.rst",
            category="4. Inside the cases",
        ),
        pdf="results/figures/phase/" + CASE_PATTERN + ".pdf",
    log:
        "logs/plot_phase/" + CASE_PATTERN + ".log",
    script:
        "../scripts/plot_phase.py"


rule figures:
    input:
        rules.plot_surrogate.output,
        get_m_eff_figures(),
        rules.plot_convergence.output,
        rules.plot_optimum_spread.output,
        get_phase_figures(),
