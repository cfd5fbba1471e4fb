"""The .kb language front end: parse source text into an AST of frozen nodes, each with its span.

>>> from aida_kb.dsl import parse
>>> result = parse('layers scene > world', "x.kb")
>>> result.module.layers[0].names[1].text
'world'
"""

from aida_kb.dsl import ast
from aida_kb.dsl.parser import ParseResult, grammar_path, parse

__all__ = ["ParseResult", "ast", "grammar_path", "parse"]
