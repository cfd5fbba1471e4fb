"""Diagnostics: Span, Severity, Diagnostic and the registry of codes; rendering lives apart."""

from aida_kb.diagnostics.core import Diagnostic, Severity, Span

__all__ = ["Diagnostic", "Severity", "Span"]
