"""The language server of the .kb language (``aida-kb lsp``), on pygls.

An editor sees what ``aida-kb lint`` reports while the expert types, and can navigate the
knowledge base: hover, go to definition, find references, completion, rename, outline and
quick fixes for the compiler's "did you mean" hints. Nothing here parses: the front end is
`aida_kb.dsl` (spans), `aida_kb.kb` (resolution, checks) and `aida_kb.diagnostics`; this
package adds only the index of which name refers to what (`aida_kb.lsp.index`) and the
protocol (`aida_kb.lsp.server`). It imports no numpy, scipy or cv2: the server starts fast.
"""
