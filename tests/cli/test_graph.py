"""`aida-kb graph`: DOT, GraphML and JSON exports of the semantic net."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import networkx as nx
import pytest

from aida_kb.cli.graph import to_dot, to_graphml, to_json
from aida_kb.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
BUILDINGS = ROOT / "kb" / "buildings.kb"
KINDS = {"part-of", "con-of", "is-a", "instance-of"}


def _small_net() -> Any:
    net: Any = nx.MultiDiGraph()
    net.add_node("House", kind="concept", layer="scene", abstract=False)
    net.add_node("Body", kind="concept", layer="world", abstract=False)
    net.add_node("Wall", kind="concept", layer="world", abstract=False)
    net.add_node('Odd "name"', kind="concept", layer=None, abstract=True)
    net.add_node("h1", kind="instance", layer="scene")
    net.add_edge("House", "Body", kind="con-of", role="body", min=1, max=1)
    net.add_edge("Body", "Wall", kind="part-of", role="front", min=1, max=1)
    net.add_edge("Body", "Wall", kind="part-of", role="sides", min=0, max=None)
    net.add_edge("Wall", 'Odd "name"', kind="is-a", role=None, min=None, max=None)
    net.add_edge("h1", "House", kind="instance-of", role=None, min=None, max=None)
    return net


def test_dot_quotes_names_and_labels_links() -> None:
    text = to_dot(_small_net(), "t")
    assert text.startswith('digraph "t" {')
    assert text.rstrip().endswith("}")
    assert '"House" [label="House\\n(scene)"];' in text
    assert '"Odd \\"name\\"" [label="Odd \\"name\\"", style=dashed];' in text
    assert '"h1" [label="h1\\n(scene)", shape=ellipse];' in text
    assert '"Body" -> "Wall" [label="part-of front [1]"' in text
    assert '"Body" -> "Wall" [label="part-of sides [0..*]"' in text
    assert '"Wall" -> "Odd \\"name\\"" [label="is-a", ' in text
    assert text.count("->") == 5


def test_graphml_round_trips_through_networkx() -> None:
    back = nx.read_graphml(io.BytesIO(to_graphml(_small_net()).encode()), force_multigraph=True)
    assert set(back.nodes) == {"House", "Body", "Wall", 'Odd "name"', "h1"}
    assert back.number_of_edges() == 5
    kinds = sorted(d["kind"] for _, _, d in back.edges(data=True))
    assert kinds == ["con-of", "instance-of", "is-a", "part-of", "part-of"]
    roles = {d.get("role") for _, _, d in back.edges(data=True)}
    assert {"front", "sides", "body"} <= roles


def test_json_is_node_link_data() -> None:
    data = json.loads(to_json(_small_net()))
    assert {n["id"] for n in data["nodes"]} == {"House", "Body", "Wall", 'Odd "name"', "h1"}
    assert len(data["edges"]) == 5
    assert {e["kind"] for e in data["edges"]} == KINDS


@pytest.mark.parametrize("fmt", ["dot", "graphml", "json"])
def test_graph_command_writes_the_net_of_buildings(
    fmt: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / f"net.{fmt}"
    assert main(["graph", str(BUILDINGS), "--format", fmt, "-o", str(out)]) == 0
    assert capsys.readouterr().out == ""
    text = out.read_text(encoding="utf-8")
    assert list(tmp_path.iterdir()) == [out]  # no temporary file left behind
    if fmt == "dot":
        assert '"House" -> "HouseBody" [label="con-of body [1]"' in text
        assert '"HipRoof" -> "Roof" [label="is-a"' in text
    elif fmt == "graphml":
        net = nx.read_graphml(io.BytesIO(text.encode()), force_multigraph=True)
        assert net.has_edge("HouseBody", "Roof")
        assert net.nodes["Region"]["layer"] == "image"
    else:
        data = json.loads(text)
        edges = {(e["source"], e["target"], e["kind"], e.get("role")) for e in data["edges"]}
        assert ("HouseBody", "Wall", "part-of", "front") in edges
        assert ("Plane", "Region", "con-of", "region") in edges


def test_graph_to_stdout(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["graph", str(BUILDINGS)]) == 0
    assert capsys.readouterr().out.startswith('digraph "buildings" {')


def test_graph_of_a_broken_kb_writes_what_parsed_and_marks_the_broken_parts(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "net.json"
    broken = ROOT / "kb" / "examples" / "broken_followon.kb"
    assert main(["graph", str(broken), "--format", "json", "-o", str(out)]) == 1
    assert "error[KB100]" in capsys.readouterr().err
    data = json.loads(out.read_text(encoding="utf-8"))
    nodes = {n["id"]: n for n in data["nodes"]}
    assert nodes["Body"]["broken"] is True  # its parent 'Boddy' is unknown
    assert nodes["Boddy"] == {"id": "Boddy", "kind": "unknown", "broken": True}
    assert nodes["Region"]["broken"] is False
    assert nodes["Region"]["layer"] == "image"
    edges = {(e["source"], e["target"], e["kind"]) for e in data["edges"]}
    assert ("Body", "Boddy", "is-a") in edges
    assert ("Shed", "Slabb", "part-of") in edges


def test_graph_of_a_file_without_a_concept_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.kb"
    bad.write_text("layers scene > world\nconcept {\n", encoding="utf-8")
    out = tmp_path / "net.dot"
    assert main(["graph", str(bad), "-o", str(out)]) == 1
    assert not out.exists()
    assert "no concept parsed" in capsys.readouterr().err


def test_dot_ranks_the_concepts_of_each_layer_in_layer_order(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["graph", str(BUILDINGS)]) == 0
    dot = capsys.readouterr().out
    assert '"layer scene" -> "layer world" [style=invis];' in dot
    assert '"layer world" -> "layer image" [style=invis];' in dot
    ranks = [line for line in dot.splitlines() if "rank=same" in line]
    assert len(ranks) == 3
    assert ranks[0].startswith('  { rank=same; "layer scene";')
    assert '"House";' in ranks[0]
    assert '"Region";' in ranks[2]
