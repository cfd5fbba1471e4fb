"""Role paths as interned values (`aida_kb.kb.paths`)."""

from __future__ import annotations

import pickle

import pytest

from aida_kb.kb.paths import ROOT, RolePath, Step


def test_parse_gives_steps_and_spells_back() -> None:
    p = RolePath.parse("body.oriels[12].left")
    assert p.steps == (Step("body"), Step("oriels", 12), Step("left"))
    assert str(p) == "body.oriels[12].left"
    assert RolePath.parse("") is ROOT
    assert RolePath.parse("self") is ROOT
    assert str(ROOT) == ""
    assert not ROOT
    assert len(p) == 3


def test_paths_are_interned() -> None:
    a = RolePath.parse("roof.front")
    assert a is RolePath((Step("roof"), Step("front")))
    assert a is RolePath.parse("roof").child("front")
    assert pickle.loads(pickle.dumps(a)) is a
    with pytest.raises(AttributeError):
        a.steps = ()


def test_structure() -> None:
    body = RolePath.parse("body")
    wall = RolePath.parse("body.wings[0].back")
    assert wall.is_under(body)
    assert not body.is_under(wall)
    assert wall.relative_to(body) is RolePath.parse("wings[0].back")
    assert body.join(wall.relative_to(body)) is wall
    assert body.join(ROOT) is body
    assert wall.relative_to(wall) is ROOT
    assert wall.parent is RolePath.parse("body.wings[0]")
    assert wall.parent.last == Step("wings", 0)
    assert RolePath.parse("body.wings").indexed(3) is RolePath.parse("body.wings[3]")
    # a step with an index is a different step: wings[0] is not under wings
    assert not wall.is_under(RolePath.parse("body.wings"))
    with pytest.raises(ValueError, match="not a part of"):
        body.relative_to(wall)
    assert sorted([wall, body]) == [body, wall]


@pytest.mark.parametrize("text", ["a..b", ".a", "a.", "1a", "a[x]", "a[1", "a[]", "a-b", "a[-1]"])
def test_bad_paths_are_refused(text: str) -> None:
    with pytest.raises(ValueError, match="not a role"):
        RolePath.parse(text)


def test_plain_and_fills() -> None:
    wing_roof = RolePath.parse("body.wings[1].roof.front")
    assert wing_roof.plain is RolePath.parse("body.wings.roof.front")
    wings = RolePath.parse("body.wings")
    assert wing_roof.fills(wings)
    assert RolePath.parse("body.wings[0]").fills(wings)
    assert not wings.fills(wings)  # the role itself is no filler
    assert not RolePath.parse("body.front").fills(wings)
    assert not RolePath.parse("other.wings[0]").fills(wings)
