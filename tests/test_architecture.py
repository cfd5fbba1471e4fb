"""The package's layering: a module imports only from its own layer or the layers below."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "aida_kb"

# Bottom to top. A package may import any package at a lower or equal index.
LAYERS: list[set[str]] = [
    {"errors", "limits", "__init__"},
    {"diagnostics"},
    {"dsl"},
    {"kb"},
    {"lsp"},  # the language server: only the front end below it (no numpy: it starts fast)
    {"geometry"},
    {"constraints"},
    {"solve"},
    {"io"},
    {"vision"},
    {"synth"},
    {"register"},
    {"testing"},
    {"texture"},
    {"interpret"},
    {"batch", "report"},
    {"cli", "__main__"},
]


def _layer_of(top: str) -> int:
    for index, names in enumerate(LAYERS):
        if top in names:
            return index
    raise AssertionError(f"aida_kb.{top} is in no layer of tests/test_architecture.py")


def _imported_tops(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    tops: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module]
            if node.module == "aida_kb":
                names = [
                    f"aida_kb.{alias.name}"
                    if (PACKAGE / alias.name).is_dir() or (PACKAGE / f"{alias.name}.py").is_file()
                    else "aida_kb.__init__"
                    for alias in node.names
                ]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "aida_kb" and len(parts) > 1:
                tops.add(parts[1])
    return tops


MODULES = sorted(PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_respect_layers(path: Path) -> None:
    rel = path.relative_to(PACKAGE)
    own = rel.parts[0].removesuffix(".py")
    own_layer = _layer_of(own)
    for top in _imported_tops(path):
        assert _layer_of(top) <= own_layer, (
            f"aida_kb/{rel} (layer {own}) imports aida_kb.{top}, a higher layer"
        )


def test_every_package_has_a_layer() -> None:
    for child in PACKAGE.iterdir():
        if child.name.startswith((".", "_")) and child.name not in {"__init__.py", "__main__.py"}:
            continue
        if child.is_dir() or child.suffix == ".py":
            _layer_of(child.name.removesuffix(".py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_no_product_module_imports_the_test_helpers(path: Path) -> None:
    rel = path.relative_to(PACKAGE)
    if rel.parts[0] == "testing":
        return
    assert "testing" not in _imported_tops(path), f"aida_kb/{rel} imports aida_kb.testing"
