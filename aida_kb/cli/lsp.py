"""`aida-kb lsp`: the language server for editors (stdio), or a check of what it shows."""

from __future__ import annotations

import argparse
from typing import Any

from aida_kb.cli._kbfiles import add_import_path_option

EXAMPLE = """\
An editor starts 'aida-kb lsp' and speaks the Language Server Protocol with it over standard
input and output (editors/vscode has a VS Code extension that does; docs/editors.md for others).

exit status (--check): 0 the server shows no errors, 1 it shows errors, 2 usage error

examples:
  aida-kb lsp                                  # serve an editor on stdin/stdout
  aida-kb lsp --check kb/buildings.kb          # start the server, open the file as an editor
                                               # does, print what it shows, stop
  aida-kb lsp --check kb/examples/broken_names.kb
"""


def register(subparsers: Any) -> None:
    """Add the `lsp` command."""
    p = subparsers.add_parser(
        "lsp",
        help="the language server for editors: diagnostics, hover, rename ... as you type",
        description=(
            "Serve the Language Server Protocol on standard input and output: the compiler's "
            "diagnostics while you type, hover, go to definition, find references, completion, "
            "rename, outline and quick fixes for .kb files. With --check, start the server, "
            "open each file through the protocol and print the diagnostics and outline it "
            "gives, then stop."
        ),
        epilog=EXAMPLE,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--check",
        nargs="+",
        metavar="FILE",
        help="drive a server as an editor would: open each .kb file, print what it shows",
    )
    add_import_path_option(p)
    p.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Serve on stdio, or check files through a server; return the exit code."""
    if not args.check:
        from aida_kb.lsp.server import serve

        serve()
        return 0
    return _check(args.check, args.import_path)


#: How the outline's symbol kinds read in the summary of --check.
_KIND_WORDS = {
    "Namespace": "layers",
    "Module": "imports",
    "Function": "templates",
    "Class": "concepts",
    "Object": "instances",
}


def _check(paths: list[str], import_paths: list[str]) -> int:
    import os
    import sys
    from pathlib import Path

    from lsprotocol import types

    from aida_kb.cli._kbfiles import EXIT_ERRORS, EXIT_OK, display_path, read_source
    from aida_kb.lsp.client import ServerClient
    from aida_kb.lsp.convert import uri_of_path

    texts = {p: read_source(Path(p)) for p in paths}
    options = {"importPaths": [os.path.abspath(d) for d in import_paths]}
    errors = 0
    with ServerClient(initialization_options=options) as client:
        for path, text in texts.items():
            uri = uri_of_path(path)
            client.open(uri, text)
            shown = client.diagnostics(uri)
            outline = client.request(
                types.TEXT_DOCUMENT_DOCUMENT_SYMBOL,
                types.DocumentSymbolParams(types.TextDocumentIdentifier(uri)),
            )
            name = display_path(Path(path))
            for d in shown:
                start = d.range.start
                level = types.DiagnosticSeverity(d.severity).name.lower() if d.severity else "?"
                message = str(d.message).replace("\n", "\n    ")
                print(
                    f"{name}:{start.line + 1}:{start.character + 1}: {level}[{d.code}]: {message}"
                )
            kinds: dict[str, int] = {}
            for s in outline or []:
                word = _KIND_WORDS.get(types.SymbolKind(s.kind).name, "other")
                kinds[word] = kinds.get(word, 0) + 1
            n_err = sum(1 for d in shown if d.severity == types.DiagnosticSeverity.Error)
            errors += n_err
            summary = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items()))
            print(
                f"{name}: {n_err} errors, {len(shown) - n_err} other diagnostics; "
                f"outline: {summary or 'empty'}"
            )
            client.close(uri)
    sys.stdout.flush()
    return EXIT_ERRORS if errors else EXIT_OK
