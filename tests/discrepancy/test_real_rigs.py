"""Two more real recordings end to end (docs/real_rigs.md): imported with their shipped maps,
diagnosed from a description without the physics (fitted on the first 60 %, judged on the rest),
and the conclusion checked against what the literature says of each system, not against anything
this code computed.

* Silverbox (Wigren and Schoukens 2013, data/silverbox/, a Parquet source): an electronic
  implementation of m y'' + d y' + k(y) y = u with k(y) = a + b y^2, "a 2nd order linear
  time-invariant system with a 3rd degree polynomial static nonlinearity around it in feedback".
  The description (robots/silverbox.toml) has a mass and nothing else: the diagnosis has to find a
  force linear in the position, one cubic in the position and a damping, and nothing it cannot
  explain; its cubic coefficient against Noël and Schoukens 2017's, b = 3.98 (identified on other
  Silverbox records, at 2441 Hz; 3.96 at 12205 Hz), in the same units (input and output in V).
* Pick-and-place machine (Juloski, Heemels, Ferrari-Trecate 2004, data/pickplace/): a vertical
  axis recorded in open loop whose dynamics the authors identify as hybrid, "unilateral contact
  and saturation phenomena characterize the hybrid dynamics": no smooth single-mode model
  explains it.  The diagnosis must not claim one with confidence, and must find a force that
  switches with the position (a contact engages at a position)."""
from pathlib import Path

import pytest

from cosim.core import Model
from cosim.discrepancy import diagnose
from cosim.importing import import_recording

DATA = Path(__file__).resolve().parents[2] / "data"


@pytest.fixture(scope="module")
def silverbox(tmp_path_factory):
    res = import_recording(DATA / "silverbox" / "SNLS80mV.parquet", DATA / "silverbox" / "silverbox_map.toml",
                           tmp_path_factory.mktemp("silverbox"), progress=False)
    assert len(res.recording) == 131072 and res.source.format == "parquet"
    # a working set of 20,000 samples of the 131,072 (blocks at the full rate) keeps this test short
    return diagnose(res.table, train_fraction=0.6, figures=False, max_samples=20000)


@pytest.fixture(scope="module")
def pickplace(tmp_path_factory):
    res = import_recording(DATA / "pickplace" / "headdata_1v6.mat", DATA / "pickplace" / "pickplace_map.toml",
                           tmp_path_factory.mktemp("pickplace"), progress=False)
    assert len(res.recording) == 60001
    return diagnose(res.table, train_fraction=0.6, figures=False)


def test_silverbox_the_diagnosis_finds_the_duffing_structure(silverbox):
    d = silverbox
    assert not d.warnings, d.warnings
    (term,) = d.discovered
    # the literature's structure: a linear spring a y and a cubic b y^3 on a mass-damper
    assert {"spring", "cubic"} <= set(term.terms), term.equation
    assert term.partial == "", term.partial                # named as the physics, no structure left
    b = term.coefficients["rail[1].force_k3"]
    assert 0 < b.ci95 < 0.5 * b.value and abs(b.value - 3.98) <= b.ci95, term.equation
    th = d.plant_parameters()
    # physical (a stable second-order system): positive stiffness, mass and damping
    assert th["rail[1].force_k1"] > 0, term.equation
    nominal_mass = Model(str(DATA.parent / "robots" / "silverbox.toml")).params()["platform.m"]
    assert th.get("platform.m", nominal_mass) + th.get("rail[1].force_inertia", 0.0) > 0, term.equation
    damping = [th.get("rail[1].viscous", 0.0) + th.get(k, 0.0) for k in ("rail[1].force_vpos", "rail[1].force_vneg")]
    assert min(damping) > 0, term.equation


def test_pickplace_no_single_smooth_model_and_a_force_switching_with_position(pickplace):
    d = pickplace
    assert not d.warnings, d.warnings
    # hybrid dynamics (contact and saturation): structure is left, nothing named with confidence
    (term,) = d.discovered
    assert term.partial, term.equation
    assert "step" in term.terms, term.equation           # a force that switches on over a short stretch of q
    th = d.plant_parameters()
    damping = [th.get("rail[1].viscous", 0.0) + th.get(k, 0.0) for k in ("rail[1].force_vpos", "rail[1].force_vneg")]
    assert min(damping) > 0, term.equation
