"""Hypothesis-verification interpretation of evidence against the knowledge base."""
