"""Ties, not rulings: a centred payload is the same physics as a heavier
platform on any recording; the alternative with more parameters fits exactly as well and
must be reported as a tie, not "ruled out" by its parameter penalty."""
from disc_helpers import run

from cosim.discrepancy import diagnose


def test_a_centred_payload_and_a_heavier_platform_are_a_tie():
    d = diagnose(run("6pus", {"payload.m": 0.0934}), figures=False, replay=False)
    first = d.effects[0]
    other = "payload" if first["key"] == "platform_mass" else "platform_mass"
    assert first["key"] in ("platform_mass", "payload"), d.conclusion
    assert other in d.ties(first["key"]), first["lookalikes"]
    look = next(a for a in first["lookalikes"] if a["effect"] == other)
    assert "ruled out" not in look["statement"] and "fits the data as well" in look["statement"], look
    assert "tie:" in d.details, d.details
    assert d.conclusion.startswith("most likely, tied with"), d.conclusion  # the paragraph says it first
