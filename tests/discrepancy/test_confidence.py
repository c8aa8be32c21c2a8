"""Named with confidence only when the fit leaves no structure: a library effect standing in
for physics the library lacks is a look-alike, not a confident name.

One blind 6-PUS recording of the engine's generator hides a backlash on one rail.  With the
backlash in the library it is named first with confidence.  With the backlash held out, a
compliance takes its place and the reading of that rail keeps structure the compliance cannot
follow (what the structure test reports is measured from the residual, not from the answer
key): the compliance must then carry the look-alike saying so, naming that channel.
"""
import json
from pathlib import Path

import pytest

from cosim.core import Model
from cosim.discrepancy import blind, diagnose
from cosim.discrepancy.diagnosis import UNEXPLAINED
from cosim.discrepancy.effects import groups_for


@pytest.fixture(scope="module")
def backlash_case(tmp_path_factory):
    spec = blind.CaseSpec("6pus_backlash_103", "6pus", ["backlash"], 103)
    csv, key = blind.make_case(spec, tmp_path_factory.mktemp("cases"), tmp_path_factory.mktemp("keys"))
    return csv, json.loads(Path(key).read_text())["effects"][0]


def test_the_truth_in_the_library_keeps_its_confident_name(backlash_case):
    csv, truth = backlash_case
    d = diagnose(csv, figures=False, replay=False)
    first = d.effects[0]
    assert first["key"] == "backlash" and first["joint"] == truth["joints"][0], d.conclusion
    assert not d.ties("backlash"), first["lookalikes"]
    assert "named with confidence" not in d.details, d.details
    assert d.conclusion.startswith("found with confidence"), d.conclusion


def test_a_stand_in_that_leaves_structure_is_not_named_with_confidence(backlash_case):
    csv, truth = backlash_case
    library = sorted({g.effect.key for g in groups_for(Model("6pus"), True)[0]} - {"backlash"})
    d = diagnose(csv, figures=False, replay=False, effects=library)
    joint = truth["joints"][0]
    assert d.unexplained and any(u["joint"] == joint for u in d.unexplained), d.conclusion
    open_channels = {u["channel"] for u in d.unexplained}
    for e in d.effects:  # every fitted effect: a tie with the structure left, naming its channels
        assert UNEXPLAINED in d.ties(e["key"]), (e["title"], e["lookalikes"])
        look = next(a for a in e["lookalikes"] if a["group"] == UNEXPLAINED)
        assert "not named with confidence" in look["statement"], look["statement"]
        assert any(c in look["statement"] for c in open_channels), look["statement"]
    assert "none named with confidence" in d.details, d.details
    assert d.conclusion.startswith("structure left, not named"), d.conclusion  # the paragraph agrees with it
    for t in d.discovered:  # nor is a discovered term named as the physics
        assert t.partial, t
        if any(u["joint"] == t.joint for u in d.unexplained):
            assert "partial fit" in t.partial, t.partial
