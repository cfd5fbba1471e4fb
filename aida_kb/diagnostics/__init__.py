"""Diagnostics: Span, Severity, Diagnostic and the registry of codes; rendering lives apart."""
