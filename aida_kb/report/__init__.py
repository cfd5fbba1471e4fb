"""The visual report of a reconstruction (`report.html`), above `interpret`.

`html.write_report` is the `extra` callback of `aida_kb.interpret.pipeline.reconstruct_scene`
that `aida-kb reconstruct` and `aida-kb demo` pass.
"""
