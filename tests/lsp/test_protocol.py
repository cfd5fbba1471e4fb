"""The language server driven through the protocol, as an editor drives it: a client process
talks JSON-RPC with ``aida-kb lsp`` over pipes (`aida_kb.lsp.client.ServerClient`)."""

from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pytest
from lsprotocol import types

from aida_kb.kb import compile_text
from aida_kb.lsp.client import ServerClient
from aida_kb.lsp.convert import uri_of_path

ROOT = Path(__file__).resolve().parents[2]
BUILDINGS = ROOT / "kb" / "buildings.kb"


def pos(text: str, needle: str, nth: int = 0, offset: int = 0) -> types.Position:
    """The position ``offset`` characters into the ``nth`` occurrence of ``needle``."""
    at = -1
    for _ in range(nth + 1):
        at = text.index(needle, at + 1)
    at += offset
    line = text.count("\n", 0, at)
    return types.Position(line, at - (text.rfind("\n", 0, at) + 1))


def apply(text: str, edits: Sequence[types.TextEdit]) -> str:
    """``text`` with the edits made (ASCII text: characters are UTF-16 units)."""
    lines = text.split("\n")
    offsets = [0]
    for line in lines:
        offsets.append(offsets[-1] + len(line) + 1)

    def at(p: types.Position) -> int:
        return offsets[p.line] + p.character

    for e in sorted(edits, key=lambda e: at(e.range.start), reverse=True):
        text = text[: at(e.range.start)] + e.new_text + text[at(e.range.end) :]
    return text


def doc(uri: str) -> types.TextDocumentIdentifier:
    return types.TextDocumentIdentifier(uri)


def hover_text(server: ServerClient, uri: str, at: types.Position) -> str:
    got = server.request(types.TEXT_DOCUMENT_HOVER, types.HoverParams(doc(uri), at))
    assert got is not None
    return str(got.contents.value)


def references(
    server: ServerClient, uri: str, at: types.Position, declaration: bool
) -> list[types.Location]:
    params = types.ReferenceParams(
        context=types.ReferenceContext(include_declaration=declaration),
        text_document=doc(uri),
        position=at,
    )
    found: list[types.Location] = server.request(types.TEXT_DOCUMENT_REFERENCES, params)
    return found


def code_positions(text: str, word: str) -> list[types.Position]:
    """Where ``word`` is written as a name: outside comments and strings."""
    blank = re.sub(
        r"//[^\n]*|/\*.*?\*/|\"[^\"\n]*\"",
        lambda m: re.sub(r"[^\n]", " ", m.group()),
        text,
        flags=re.S,
    )
    return [_at(blank, m.start()) for m in re.finditer(rf"\b{word}\b", blank)]


def _offset(text: str, p: types.Position) -> int:
    lines = text.split("\n")
    return sum(len(line) + 1 for line in lines[: p.line]) + p.character


def _at(text: str, offset: int) -> types.Position:
    line = text.count("\n", 0, offset)
    return types.Position(line, offset - (text.rfind("\n", 0, offset) + 1))


@pytest.fixture
def buildings(server: ServerClient) -> Iterator[tuple[str, str]]:
    """kb/buildings.kb open in the server: its URI and text."""
    uri = uri_of_path(str(BUILDINGS))
    text = BUILDINGS.read_text(encoding="utf-8")
    server.open(uri, text)
    yield uri, text
    server.close(uri)


def test_recorded_editing_session_of_buildings_kb(server: ServerClient) -> None:
    """Open kb/buildings.kb, type a misspelt concept, see the diagnostic, accept the quick fix,
    hover, go to definition, rename a role."""
    uri = uri_of_path(str(BUILDINGS))
    text = BUILDINGS.read_text(encoding="utf-8")
    server.open(uri, text)
    assert server.diagnostics(uri) == []

    # type a misspelt concept: "Floor" of HouseBody's floor becomes "Flor"
    start = pos(text, "part floor: Floor", 0, len("part floor: "))
    word = types.Range(start, types.Position(start.line, start.character + len("Floor")))
    version = server.change(uri, "Flor", word)
    text = apply(text, [types.TextEdit(word, "Flor")])
    shown = server.diagnostics(uri, version)
    typed = types.Range(start, types.Position(start.line, start.character + 4))
    at_typed = [d for d in shown if d.range == typed]
    assert len(at_typed) == 1  # (follow-on errors elsewhere are the compiler's to suppress)
    d = at_typed[0]
    assert d.code == "KB100"
    assert d.severity == types.DiagnosticSeverity.Error
    assert d.source == "aida-kb"
    assert d.message.startswith("unknown concept 'Flor' for role 'floor' of HouseBody")
    assert "hint: did you mean 'Floor'?" in d.message
    assert d.code_description is not None
    assert d.code_description.href.endswith("docs/diagnostics.md#kb100")

    # accept the quick fix
    actions = server.request(
        types.TEXT_DOCUMENT_CODE_ACTION,
        types.CodeActionParams(doc(uri), typed, types.CodeActionContext(shown)),
    )
    assert [a.title for a in actions] == ["Replace 'Flor' with 'Floor'"]
    assert actions[0].kind == types.CodeActionKind.QuickFix
    edits = actions[0].edit.changes[uri]
    version = server.change(uri, "Floor", edits[0].range)
    text = apply(text, edits)
    assert text == BUILDINGS.read_text(encoding="utf-8")
    assert server.diagnostics(uri, version) == []

    # hover: a concept (doc, layer, inherited members), an attribute (unit, range), a template
    wall = hover_text(server, uri, pos(text, "left, right: Wall", 0, len("left, right: ")))
    assert "concept Wall is-a Plane" in wall
    assert "A wall: vertical up to a few degrees." in wall
    assert "layer: **world**" in wall
    assert "`con-of region: Region [0..1]` — inherited from **Plane**" in wall
    assert "`attribute tilt: angle in [85 deg, 95 deg] = 90 deg is slope(self)` — own" in wall
    pitch = hover_text(server, uri, pos(text, "tilted by front.pitch", 0, len("tilted by front.")))
    assert "declared in concept **RoofPlane**" in pitch
    assert "unit: rad; write deg or rad" in pitch
    assert "range: [0 deg, 75 deg]" in pitch
    perp = hover_text(server, uri, pos(text, "corner_fl: perpendicular", 0, len("corner_fl: ")))
    assert "template perpendicular(a: Plane, b: Plane, tol: angle = 1 deg)" in perp
    assert "Two planes meet at a right angle" in perp
    edge = hover_text(server, uri, pos(text, "measure edge(edge(front, left))", 0, 9))
    assert edge.startswith("```kb\nedge(a, b)\n```\n\nprimitive relation: the edge where")

    # go to definition: 'roof' in HouseBody's roof.front, then 'front' after it
    eaves = pos(
        text, "eaves: parallel_edges(front, roof.front", 0, len("eaves: parallel_edges(front, ")
    )
    got = server.request(types.TEXT_DOCUMENT_DEFINITION, types.DefinitionParams(doc(uri), eaves))
    assert len(got) == 1
    assert got[0].uri == uri
    assert got[0].range.start == pos(text, "part roof: Roof", 0, len("part "))
    front = types.Position(eaves.line, eaves.character + len("roof."))
    got = server.request(types.TEXT_DOCUMENT_DEFINITION, types.DefinitionParams(doc(uri), front))
    # a path through the abstract role: a declaration of one of the roofs having 'front'
    # (GableRoof's, AsymmetricGableRoof's: the first two 'part front, back: RoofPlane')
    assert got[0].range.start in [
        pos(text, "part front, back: RoofPlane", n, len("part ")) for n in (0, 1)
    ]

    # rename the role 'roof' of HouseBody: Wing's own 'roof' stays
    prepared = server.request(
        types.TEXT_DOCUMENT_PREPARE_RENAME, types.PrepareRenameParams(doc(uri), eaves)
    )
    assert prepared.placeholder == "roof"
    edit = server.request(types.TEXT_DOCUMENT_RENAME, types.RenameParams(doc(uri), eaves, "cover"))
    assert set(edit.changes) == {uri}
    house_body = text[text.index("concept HouseBody") : text.index("concept Region")]
    assert len(edit.changes[uri]) == len(code_positions(house_body, "roof"))
    renamed = apply(text, edit.changes[uri])
    assert "    part cover: Roof\n" in renamed
    assert "    part roof: GableRoof\n" in renamed  # Wing's
    assert "constraint eaves: parallel_edges(front, cover.front, back, cover.back)" in renamed
    assert compile_text(renamed, str(BUILDINGS)).diagnostics == ()
    server.close(uri)


def test_find_references_of_a_concept_and_a_linked_role(
    server: ServerClient, buildings: tuple[str, str]
) -> None:
    uri, text = buildings
    at = pos(text, "concept Wall is-a", 0, len("concept "))
    got = references(server, uri, at, True)
    assert [loc.range.start for loc in got] == code_positions(text, "Wall")
    # 'front' of GableRoof: HouseBody's roof.front names it and HipRoof's front at once, so
    # the two are one group; Wing's roof is a GableRoof, so Wing's roof.front is found too
    at = pos(text, "part front, back: RoofPlane", 0, len("part "))
    got = references(server, uri, at, False)
    gable_and_hip = text.index("concept GableRoof"), text.index("concept FlatRoof")
    expected = [
        p
        for p in code_positions(text, "front")
        if gable_and_hip[0] <= _offset(text, p) < gable_and_hip[1]
        or text[: _offset(text, p)].endswith("roof.")
    ]
    declarations = [
        pos(text, "part front, back: RoofPlane", 0, 5),
        pos(text, "part front, back: RoofPlane", 1, 5),  # AsymmetricGableRoof's
        pos(text, "part front, back, left, right: RoofPlane", 0, 5),
    ]
    assert [loc.range.start for loc in got] == [p for p in expected if p not in declarations]
    assert len(got) >= 10  # the shipped file: 7 in the two roofs, 16 through roof.front


LIB = """\
abstract concept Plane in world {
    "A planar face."
    con-of region: Region [0..1]
}

concept Wall is-a Plane {
    attribute tilt: angle in [85 deg, 95 deg] = 90 deg is slope(self)
}

concept Region in image {
    measure position(self) +- 1 px reject above 4 px
}
"""

ROOT_KB = """\
layers scene > world > image
import "walls.kb"

concept House in scene {
    con-of body: Box
}

concept Box in world {
    part front, side: Wall
    constraint angle(front, side) == 90 deg +- front.tilt
}
"""


def test_definition_references_and_rename_across_an_import(
    server: ServerClient, tmp_path: Path
) -> None:
    (tmp_path / "walls.kb").write_text(LIB, encoding="utf-8")
    (tmp_path / "house.kb").write_text(ROOT_KB, encoding="utf-8")
    root, lib = uri_of_path(str(tmp_path / "house.kb")), uri_of_path(str(tmp_path / "walls.kb"))
    server.open(root, ROOT_KB)
    assert server.diagnostics(root) == []
    wall = pos(ROOT_KB, "side: Wall", 0, len("side: "))
    got = server.request(types.TEXT_DOCUMENT_DEFINITION, types.DefinitionParams(doc(root), wall))
    assert [(g.uri, g.range.start) for g in got] == [(lib, pos(LIB, "concept Wall", 0, 8))]

    # the attribute tilt, declared in walls.kb, used in house.kb as front.tilt
    tilt = pos(ROOT_KB, "front.tilt", 0, len("front."))
    got = references(server, root, tilt, True)
    assert [(g.uri, g.range.start) for g in got] == [
        (root, tilt),
        (lib, pos(LIB, "attribute tilt", 0, len("attribute "))),
    ] or [(g.uri, g.range.start) for g in got] == [
        (lib, pos(LIB, "attribute tilt", 0, len("attribute "))),
        (root, tilt),
    ]
    # rename the attribute from its use in house.kb: the declaration in walls.kb follows
    edit = server.request(types.TEXT_DOCUMENT_RENAME, types.RenameParams(doc(root), tilt, "lean"))
    assert apply(ROOT_KB, edit.changes[root]).count("front.lean") == 1
    assert "attribute lean: angle" in apply(LIB, edit.changes[lib])
    edit = server.request(types.TEXT_DOCUMENT_RENAME, types.RenameParams(doc(root), wall, "Facade"))
    assert set(edit.changes) == {root, lib}
    new_root = apply(ROOT_KB, edit.changes[root])
    new_lib = apply(LIB, edit.changes[lib])
    assert "part front, side: Facade" in new_root
    assert "concept Facade is-a Plane" in new_lib
    (tmp_path / "walls.kb").write_text(new_lib, encoding="utf-8")
    assert compile_text(new_root, str(tmp_path / "house.kb")).diagnostics == ()

    # the import string leads to the file
    at = pos(ROOT_KB, '"walls.kb"', 0, 2)
    got = server.request(types.TEXT_DOCUMENT_DEFINITION, types.DefinitionParams(doc(root), at))
    assert [g.uri for g in got] == [lib]
    server.close(root)


def test_references_and_rename_reach_workspace_files_that_are_not_open(
    server: ServerClient, tmp_path: Path
) -> None:
    """Only the imported file is open: its importer is found in the workspace folder."""
    (tmp_path / "walls.kb").write_text(LIB, encoding="utf-8")
    (tmp_path / "house.kb").write_text(ROOT_KB, encoding="utf-8")
    (tmp_path / "other.kb").write_text("layers a\nconcept Wall in a { }\n", encoding="utf-8")
    root, lib = uri_of_path(str(tmp_path / "house.kb")), uri_of_path(str(tmp_path / "walls.kb"))
    folder = types.WorkspaceFolder(uri_of_path(str(tmp_path)), "kb")
    server.notify(
        types.WORKSPACE_DID_CHANGE_WORKSPACE_FOLDERS,
        types.DidChangeWorkspaceFoldersParams(types.WorkspaceFoldersChangeEvent([folder], [])),
    )
    try:
        server.open(lib, LIB)
        server.diagnostics(lib)
        tilt = pos(LIB, "attribute tilt", 0, len("attribute "))
        got = references(server, lib, tilt, False)
        assert [(g.uri, g.range.start) for g in got] == [
            (root, pos(ROOT_KB, "front.tilt", 0, len("front.")))
        ]
        wall = pos(LIB, "concept Wall", 0, len("concept "))
        edit = server.request(
            types.TEXT_DOCUMENT_RENAME, types.RenameParams(doc(lib), wall, "Facade")
        )
        # other.kb declares a Wall of its own knowledge base: not renamed
        assert set(edit.changes) == {root, lib}
        assert "part front, side: Facade" in apply(ROOT_KB, edit.changes[root])
        assert "concept Facade is-a Plane" in apply(LIB, edit.changes[lib])
        # workspace symbols: the open file's and those of the folder's files, each once
        got = server.request(types.WORKSPACE_SYMBOL, types.WorkspaceSymbolParams(query="wal"))
        assert [(s.name, s.container_name) for s in got] == [
            ("Wall", "other.kb"),
            ("Wall", "walls.kb"),
        ]
        server.close(lib)
    finally:
        server.notify(
            types.WORKSPACE_DID_CHANGE_WORKSPACE_FOLDERS,
            types.DidChangeWorkspaceFoldersParams(types.WorkspaceFoldersChangeEvent([], [folder])),
        )


def test_a_library_is_shown_in_the_context_of_a_file_importing_it(
    server: ServerClient, tmp_path: Path
) -> None:
    """A file without layers (a library) names a concept its importer declares: alone that is
    an unknown concept; in the workspace of the importer, as lint has it, it is not."""
    library = "concept Wall is-a Plane {\n    attribute tilt: angle\n}\n"
    root_kb = ROOT_KB.replace(
        'import "walls.kb"', 'import "walls.kb"\nabstract concept Plane in world { }'
    )
    (tmp_path / "walls.kb").write_text(library, encoding="utf-8")
    (tmp_path / "house.kb").write_text(root_kb, encoding="utf-8")
    lib = uri_of_path(str(tmp_path / "walls.kb"))
    server.open(lib, library)
    alone = server.diagnostics(lib)
    assert [(d.code, d.message.split("\n")[0]) for d in alone] == [
        ("KB100", "unknown concept 'Plane' as the parent of Wall")
    ]
    server.close(lib)
    folder = types.WorkspaceFolder(uri_of_path(str(tmp_path)), "kb")
    server.notify(
        types.WORKSPACE_DID_CHANGE_WORKSPACE_FOLDERS,
        types.DidChangeWorkspaceFoldersParams(types.WorkspaceFoldersChangeEvent([folder], [])),
    )
    try:
        server.open(lib, library)
        # house.kb declares Plane and imports walls.kb: what it finds in walls.kb is a warning
        assert [d.code for d in server.diagnostics(lib)] == ["KB302"]
        server.close(lib)
    finally:
        server.notify(
            types.WORKSPACE_DID_CHANGE_WORKSPACE_FOLDERS,
            types.DidChangeWorkspaceFoldersParams(types.WorkspaceFoldersChangeEvent([], [folder])),
        )


def test_an_error_in_an_imported_file_shows_at_the_import(
    server: ServerClient, tmp_path: Path
) -> None:
    (tmp_path / "walls.kb").write_text(LIB.replace("con-of region: Region", "con-of region: Regin"))
    root = uri_of_path(str(tmp_path / "house.kb"))
    server.open(root, ROOT_KB)
    shown = server.diagnostics(root)
    errors = [d for d in shown if d.severity == types.DiagnosticSeverity.Error]
    assert [(d.code, d.range.start.line) for d in errors] == [("KB100", 1)]
    assert errors[0].message.startswith("in imported file walls.kb:3: unknown concept 'Regin'")
    lib = uri_of_path(str(tmp_path / "walls.kb"))
    assert errors[0].related_information[0].location.uri == lib
    # the import is fixed and saved in the editor: the file importing it is compiled again
    (tmp_path / "walls.kb").write_text(LIB, encoding="utf-8")
    server.open(lib, LIB)
    server.save(lib)
    assert server.diagnostics(root) == []
    server.close(lib)
    server.close(root)


def labels(items: Any) -> list[str]:
    return [i.label for i in (items.items if hasattr(items, "items") else items)]


def complete(server: ServerClient, uri: str, text: str, at: types.Position) -> list[str]:
    got = server.request(types.TEXT_DOCUMENT_COMPLETION, types.CompletionParams(doc(uri), at))
    return labels(got)


def test_completion_in_context(server: ServerClient, tmp_path: Path) -> None:
    uri = uri_of_path(str(tmp_path / "b.kb"))
    text = BUILDINGS.read_text(encoding="utf-8")
    server.open(uri, text)
    server.diagnostics(uri)

    def typed(line_start: str, fragment: str) -> list[str]:
        at = pos(text, line_start)
        version = server.change(uri, fragment, types.Range(at, at))
        server.diagnostics(uri, version)
        here = types.Position(at.line, at.character + len(fragment))
        got = complete(server, uri, text, here)
        server.change(uri, "", types.Range(at, here))
        return got

    body = "    frame from front\n    orient front: forward\n    orient back"
    # a concept after 'part NAME:'
    concepts = typed(body, "    part porch: ")
    assert {"Wall", "Floor", "RoofPlane", "HouseBody"} <= set(concepts)
    assert "angle" not in concepts
    # the members of the roof's concept after 'roof.' (Wing's roof is a GableRoof), and in
    # HouseBody, whose roof is any Roof, those of the specialisations too
    members = typed(body, "    constraint perpendicular(front, roof.")
    assert members == ["back", "front"]
    house = "    orient floor: downward"
    members = typed(house, "    constraint perpendicular(front, roof.")
    assert set(members) == {"front", "back", "left", "right", "top"}
    # units after a number
    assert typed(body, "    constraint angle(front, left) == 90 ") == [
        "deg",
        "rad",
        "m",
        "cm",
        "mm",
        "px",
    ]
    # member keywords at the start of a member, declaration keywords at the top level
    assert "con-of" in typed(body, "    ")
    assert "attach" in typed(body, "    ")
    assert typed("concept House in scene", "")[:3] == ["layers", "import", "template"]
    # layers after 'concept NAME in', value types after 'attribute NAME:'
    assert typed("concept House in scene", "concept Porch in ") == ["scene", "world", "image"]
    assert typed(body, "    attribute span: ") == ["angle", "length", "number"]
    # the .kb files beside the document after 'import "'
    (tmp_path / "lib").mkdir()
    (tmp_path / "lib" / "walls.kb").write_text("", encoding="utf-8")
    (tmp_path / "roofs.kb").write_text("", encoding="utf-8")
    assert typed("concept House in scene", 'import "') == ["roofs.kb", "lib/walls.kb"]
    # the keywords the grammar allows next
    assert typed(body, "    adjacent ") == ["ring", "pairs"]
    assert typed(body, "    unseen back: ") == ["mirror", "at", "reach"]
    assert typed(body, "    orient top: upward ") == ["tilted"]
    assert typed(body, "    measure edge(self) +- 1 px reject ") == ["above"]
    assert typed(body, "    part doors: Wall [0..") == []  # a cardinality takes no unit
    # templates, primitives and roles inside a constraint
    inside = typed(body, "    constraint ")
    assert {"perpendicular", "parallel_planes", "angle", "edge", "front", "roof", "self"} <= set(
        inside
    )
    server.close(uri)


def test_signature_help_marks_the_parameter_being_written(
    server: ServerClient, buildings: tuple[str, str]
) -> None:
    uri, text = buildings

    def help_at(needle: str, offset: int) -> types.SignatureHelp:
        at = pos(text, needle, 0, offset)
        got = server.request(
            types.TEXT_DOCUMENT_SIGNATURE_HELP, types.SignatureHelpParams(doc(uri), at)
        )
        assert got is not None
        return got  # type: ignore[no-any-return]

    line = "constraint corner_fl: perpendicular(front, left)"
    got = help_at(line, line.index("left"))
    (sig,) = got.signatures
    assert sig.label == "perpendicular(a: Plane, b: Plane, tol: angle = 1 deg)"
    assert got.active_parameter == 1
    start, end = sig.parameters[1].label
    assert sig.label[start:end] == "b: Plane"
    line = "constraint ridge: parallel(edge(roof.front, roof.back), edge("
    got = help_at(line, line.index("roof.back"))  # inside the inner primitive
    assert got.signatures[0].label == "edge(a, b)"
    assert got.active_parameter == 1
    got = help_at("90 deg is slope(self)", len("90 deg is slope("))
    assert got.signatures[0].label == "slope(a)"
    assert got.signatures[0].documentation.value == "measure: gives angle"


def test_document_symbols_outline(server: ServerClient, buildings: tuple[str, str]) -> None:
    uri, text = buildings
    got = server.request(types.TEXT_DOCUMENT_DOCUMENT_SYMBOL, types.DocumentSymbolParams(doc(uri)))
    names = [s.name for s in got]
    declared = re.findall(r"^(?:abstract )?(?:concept|template) (\w+)", text, re.M)
    assert names == ["layers", *declared]
    house_body = got[names.index("HouseBody")]
    assert house_body.kind == types.SymbolKind.Class
    assert house_body.detail == "in world"
    members = [(c.name, c.detail) for c in house_body.children]
    assert members[:6] == [
        ("front", "part: Wall"),
        ("back", "part: Wall"),
        ("left", "part: Wall"),
        ("right", "part: Wall"),
        ("floor", "part: Floor"),
        ("roof", "part: Roof"),
    ]
    assert ("depth", "length") in members
    assert ("eaves", "constraint") in members
    perp = got[names.index("perpendicular")]
    assert [c.name for c in perp.children] == ["a", "b", "tol"]


def test_rename_refuses_a_keyword_or_a_taken_name(
    server: ServerClient, buildings: tuple[str, str]
) -> None:
    uri, text = buildings
    wall = pos(text, "concept Wall", 0, len("concept "))
    for new, why in [
        ("concept", "keyword"),
        ("Floor", "a concept named 'Floor' exists already"),
        ("2walls", "is not a name"),
    ]:
        with pytest.raises(Exception, match=why):
            server.request(types.TEXT_DOCUMENT_RENAME, types.RenameParams(doc(uri), wall, new))
    depth = pos(text, "attribute depth", 0, len("attribute "))
    with pytest.raises(Exception, match="concept HouseBody has a member named 'width' already"):
        server.request(types.TEXT_DOCUMENT_RENAME, types.RenameParams(doc(uri), depth, "width"))


def test_the_server_imports_no_numpy_scipy_cv2() -> None:
    probe = (
        "import sys, aida_kb.cli.lsp, aida_kb.lsp.server;"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('numpy', 'scipy', 'cv2')))"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, check=True, timeout=60
    )
    assert done.stdout.strip() == "[]"


def test_a_misspelt_unit_gets_its_quick_fix_and_its_code_explained(
    server: ServerClient, tmp_path: Path
) -> None:
    uri = uri_of_path(str(tmp_path / "unit.kb"))
    text = "layers world\nconcept Box in world {\n    attribute tilt: angle = 90 dge\n}\n"
    server.open(uri, text)
    (d,) = [d for d in server.diagnostics(uri) if d.severity == types.DiagnosticSeverity.Error]
    assert d.code == "KB003"
    assert d.range.start == pos(text, "dge")
    actions = server.request(
        types.TEXT_DOCUMENT_CODE_ACTION,
        types.CodeActionParams(doc(uri), d.range, types.CodeActionContext([d])),
    )
    assert [a.title for a in actions] == ["Replace 'dge' with 'deg'"]
    fixed = apply(text, actions[0].edit.changes[uri])
    assert fixed.endswith("= 90 deg\n}\n")
    shown = hover_text(server, uri, pos(text, "dge", 0, 1))
    assert "[KB003](" in shown
    assert "unknown unit — `aida-kb explain KB003`" in shown
    server.close(uri)
