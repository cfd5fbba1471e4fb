"""Constraint templates compiled to vectorised residuals with analytic Jacobians."""
