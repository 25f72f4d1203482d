"""Figures, saved as PNG and PDF: surrogate maps, convergence histories, the fidelity study."""
