"""Two effects in one recording, one of the library and one no library names: both found, neither
absorbed by the other.  6-PUS recordings simulated by the core in closed loop with the blind
generator's sensor noise; the truth is the plant's parameters (the hidden values below), never
anything the diagnosis computed.

* a cable on the platform (a platform force) beside a large library viscous friction on one rail
  (twice the top of the blind generator's range);
* a friction in a zone of one rail's stroke (the family ``stroke``) beside a library Coulomb
  friction on another rail.

The library's viscous friction + a friction growing with the load on one joint is
tests/discrepancy/test_families.py's last case."""
import pytest

from cosim.core import Model
from cosim.discrepancy import diagnose
from cosim.discrepancy.diagnosis import tied

from test_diagnose_platform_force import ANCHOR_OFFSET, TENSION, _record

VISCOUS = 1.5  # N s/m on rail 2 (the blind generator draws 0.3-0.8)
ZONE = {"rail[5].force_czone": 0.06, "rail[5].force_czone_w": -0.001}  # N, m: below q_z on rail 5
COULOMB = 0.03  # N on rail 1


def _confident(d):
    return [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]


@pytest.fixture(scope="module")
def cable_and_viscous():
    A = Model("6pus").home()[:3] + ANCHOR_OFFSET
    hidden = {"cable.tension": TENSION, **{f"cable.anchor_{a}": float(v) for a, v in zip("xyz", A)},
              "rail[2].viscous": VISCOUS}
    return diagnose(_record(hidden, seed=5), figures=False, replay=False)


def test_a_cable_beside_a_large_viscous_friction_both_found(cable_and_viscous):
    d = cable_and_viscous
    pf = d.platform_force
    assert pf is not None and pf.family.startswith("cable"), d.conclusion
    assert abs(pf.params["cable.tension"] / TENSION - 1) < 0.15, pf.equation
    # the viscous friction named with its value, not absorbed into the cable nor the cable into it
    assert "viscous" in _confident(d), d.conclusion
    assert abs(d.theta["rail[2].viscous"] / VISCOUS - 1) < 0.15, d.theta
    assert set(_confident(d)) == {"viscous"}, d.conclusion


@pytest.fixture(scope="module")
def zone_and_coulomb():
    m = Model("6pus")
    q_home = m.ik(m.home())
    hidden = dict(ZONE, **{"rail[5].force_czone_q": float(q_home[4]), "rail[1].coulomb": COULOMB})
    return diagnose(_record(hidden, seed=6), figures=False, replay=False, families=True), hidden


def test_a_friction_zone_beside_a_library_coulomb_friction_both_found(zone_and_coulomb):
    d, hidden = zone_and_coulomb
    assert "coulomb" in d.named(), d.conclusion
    assert abs(d.theta["rail[1].coulomb"] / COULOMB - 1) < 0.15, d.theta
    (term,) = [t for t in d.discovered if t.joint == 5]
    assert "zone" in term.terms, term.equation
    got = term.coefficients["rail[5].force_czone"].value
    assert abs(got / ZONE["rail[5].force_czone"] - 1) < 0.15, term.equation
    assert not [t for t in d.discovered if t.joint == 1], d.conclusion  # the Coulomb friction is not a term
    assert set(_confident(d)) <= {"coulomb"}, d.conclusion
