"""Two selected library effects whose regressors are one column over the samples the fit
used are a tie, not two confident names: a drive's dead zone under an effort that keeps one
sign is a constant, the drive's offset.  The columns are built here from the effects' laws
(offset: d tau / d c = 1; dead zone of width w under a command u: tau = u - w sgn(u) outside
the zone, d tau / d w = -sgn(u)), not from the engine."""
from types import SimpleNamespace

import numpy as np

from cosim.discrepancy import inference
from cosim.discrepancy.diagnosis import tied
from cosim.discrepancy.effects import BY_KEY, Group
from cosim.discrepancy.selection import Attribution


def _pair(monkeypatch, u):
    offset = Attribution(Group(BY_KEY["offset"], 0, ("rail[1].offset",)), {}, {}, -50.0, importance=40.0)
    dead = Attribution(Group(BY_KEY["dead_zone"], 0, ("rail[1].dead_zone",)), {}, {}, -30.0, importance=30.0)
    J = np.column_stack([np.ones_like(u), -np.sign(u)])
    monkeypatch.setattr(inference, "jacobian", lambda st, selected, theta: (J, ["rail[1].offset",
                                                                                 "rail[1].dead_zone"]))
    st = SimpleNamespace(n_eff=float(len(u)), k=lambda g: len(g.params))
    sel = SimpleNamespace(selected=(offset, dead), theta={})
    return inference._one_column(st, sel)


def test_a_dead_zone_under_a_one_signed_effort_is_one_column_with_the_offset(monkeypatch):
    rng = np.random.default_rng(3)
    u = 5.0 + rng.standard_normal(2000)            # a rail carrying gravity: the noise never crosses zero
    u[:20] = -1.0                                  # 1 % of the samples of the other sign
    looks = _pair(monkeypatch, u)
    assert [c["effect"] for c in looks[0]] == ["dead_zone"] and [c["effect"] for c in looks[1]] == ["offset"]
    assert all(c["collinear"] and tied(c) for c in looks[0] + looks[1])
    # a fraction p of the other sign: the cosine of the two columns is |1 - 2 p| = 0.98 by hand,
    # a variance inflation of 1 / (1 - 0.98^2) = 25
    assert abs(looks[0][0]["correlation"] - 0.98) < 1e-9


def test_efforts_of_both_signs_separate_them(monkeypatch):
    u = np.sin(np.linspace(0.0, 20.0, 2000)) + 0.3  # about 40 % of the samples negative
    looks = _pair(monkeypatch, u)
    assert looks == [[], []]
