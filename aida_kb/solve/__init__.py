"""Weighted least squares over parts and cameras, hierarchical refinement, residual report."""
