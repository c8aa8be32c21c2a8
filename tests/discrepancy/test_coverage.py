"""The stated 95 % intervals hold the truth in at least 90 % of the estimates, over at least 100
estimates from blind cases with known answers of two generators: the engine's own
(``cosim.discrepancy.blind``: every library type of the 6-PUS, every force of
``blind.UNLISTED``) and MuJoCo's 6-PUS (every effect type of ``bench/foreign/mujoco_blind.py``'s
plan, every force law of ``bench/discovery_mujoco_bench.py``).

The cases are those of ``bench/coverage_bench.py --short`` (one list, ``coverage_bench.short_cases``):
every type of each generator once at a fixed seed, chosen before any result and none left out
for missing.  Shorter recordings than the bench's (the own generator at 500 Hz, 7.2 s, every
joint effect on every joint; MuJoCo 6 s); the bench runs the same count on the benchmark's
recordings and more seeds.  Each recording is diagnosed knowing only its path; the truth comes
from the answer keys (the generator's key, MuJoCo's model), never from the engine.  On failure
the assertion prints the table per source and every miss in half widths."""
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import coverage_bench as cb  # noqa: E402


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    return cb.run_all(cb.short_cases(), cb.SHORT, tmp_path_factory.mktemp("coverage"), jobs=2)


def test_the_stated_intervals_hold_the_truth_in_at_least_90_percent(rows):
    k, n = cb.coverage(rows)
    text = cb.table(rows)
    print(text)  # the table per source (shown with -rP, and in every assertion below)
    assert not [r for r in rows if "failed" in r], text
    assert {r["source"] for r in rows} == set(cb.SOURCES), text
    # every source contributes estimates (a source that states none would not be counted at all)
    for s in cb.SOURCES:
        assert sum(len(r["estimates"]) for r in rows if r["source"] == s) >= 10, (s, text)
    assert n >= cb.MIN_ESTIMATES, f"only {n} estimates with a truth\n{text}"
    assert k >= cb.MIN_COVERAGE * n, f"{k}/{n} intervals hold the truth\n{text}"


def test_estimates_are_counted_against_the_answer_key():
    """What one estimate is: a parameter stated with an interval and a true value; a ripple's
    sine and cosine as one amplitude, in the diagnosis and in the truth alike."""
    from types import SimpleNamespace as NS

    from cosim.discrepancy.discovery import Coefficient

    term = NS(coefficients={"rail[2].force_sin": Coefficient("rail[2].force_sin", 3.0, 0.3, "N"),
                            "rail[2].force_cos": Coefficient("rail[2].force_cos", 4.0, 0.4, "N")},
              shape={"rail[2].force_period": 0.01, "rail[2].force_qc": 0.2},
              shape_ci95={"rail[2].force_period": 1e-4})
    d = NS(effects=[{"params": {"rail[1].coulomb": {"value": 0.030, "ci95": 0.002},
                                "rail[3].viscous": {"value": 0.5, "ci95": float("nan")}}}],
           discovered=[term])
    truth = {"rail[1].coulomb": 0.033, "rail[3].viscous": 0.5, "rail[2].force_sin": 0.0,
             "rail[2].force_cos": 5.2, "rail[2].force_period": 0.0101, "rail[2].force_qc": 0.2, "payload.m": 0.1}
    got = {p: (v, h, t) for p, v, h, t in cb.estimates(d, truth)}
    # no interval (nan), a fixed centre (no stated half width) and what the diagnosis does not
    # state (payload.m) are not estimates
    assert set(got) == {"rail[1].coulomb", "rail[2].force_amplitude", "rail[2].force_period"}
    assert got["rail[2].force_amplitude"] == pytest.approx((5.0, 0.5, 5.2))
    rows = [{"source": s, "case": s, "estimates": cb.estimates(d, truth) if s == "own library" else []}
            for s in cb.SOURCES]
    assert cb.coverage(rows) == (2, 3)  # the Coulomb friction misses by 1.5 half widths
    assert "rail[1].coulomb = 0.03 +- 0.002, truth 0.033 (-1.50)" in cb.table(rows)
