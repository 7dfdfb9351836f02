"""Solvers: the heyoka reference integrator and the analytical (closed-form) solver."""
