"""The design stage: the C_eq table, its spline surrogate, and the SLSQP optimisation under the budget."""
