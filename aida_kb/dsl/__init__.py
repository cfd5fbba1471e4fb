"""The .kb language front end: parse source text into an AST of frozen nodes, each with its span."""
