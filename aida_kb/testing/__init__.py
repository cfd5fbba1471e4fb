"""Helpers for tests and benchmarks, not used by the product: synthetic least-squares houses
(`houses`: the paper's 28-part house and rows of them, perturbed starts) and simulated image
segments of a known model (`segments`). `tests/test_architecture.py` checks that no other
package of aida_kb imports this one.
"""
