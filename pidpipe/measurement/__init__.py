"""From per-cycle dissipation to C_eq with its uncertainty: statistics, steady state, timestep plan, adaptive runs."""
