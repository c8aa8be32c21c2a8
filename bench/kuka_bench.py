"""The KUKA KR300 R2500 ultra end to end (docs/kuka.md): rigid model identified on trajectory A,
judged on B and C; drive terms against the makers' ``para``; gear elasticity and backlash from the
motor and link encoders; the axis-2 counterbalance as a position-dependent torque (a figure).

Data: data/kuka_kr300/kr300_<A|B|C>.mat (JonasWeigand/Robot_Identification, MIT licence), imported
with data/kuka_kr300/kr300_map.toml.  Run: ``PYTHONPATH=. .venv/bin/python bench/kuka_bench.py
[--cutoff 2] [--figure docs/figures/kuka_counterbalance.png] [--out out/kuka] [--no-diagnose]``.  About 2 min
(30 s without the diagnoses; the open-loop replay
about 5 s).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.io
import scipy.signal

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from cosim.core import Model  # noqa: E402
from cosim.identification import identify  # noqa: E402
from cosim.identification.encoders import drive_elasticity  # noqa: E402
from cosim.identification.identify import _lowpass, prepare  # noqa: E402
from cosim.importing import to_recording  # noqa: E402

DATA = REPO / "data" / "kuka_kr300"
ROBOT = str(REPO / "robots" / "kr300.toml")


def recordings() -> dict:
    return {t: to_recording(str(DATA / f"kr300_{t}.mat"), str(DATA / "kr300_map.toml")) for t in "ABC"}


def para() -> dict:
    p = scipy.io.loadmat(str(DATA / "kr300_A.mat"), squeeze_me=True, struct_as_record=False)["para"]
    return {k: np.atleast_1d(getattr(p, k)).astype(float) for k in p._fieldnames}


def held_out(model, rec, cutoff):
    """Per axis: RMS of (predicted - recorded) efforts over RMS of the recorded ones [%], the
    mean error [N m], the filtered q, the error series (the efforts and the model's inverse
    dynamics through the identification's low-pass, its transients dropped)."""
    q, qd, qdd, tau, fs = prepare(rec.time, rec.q, rec.qd, rec.tau, cutoff)
    b, a = _lowpass(cutoff, fs)
    pred = scipy.signal.filtfilt(b, a, model.inverse_dynamics(q, qd, qdd), axis=0)
    tf = scipy.signal.filtfilt(b, a, tau, axis=0)
    e = int(np.ceil(fs / cutoff))
    d, tf = (pred - tf)[e:-e], tf[e:-e]
    return 100 * np.sqrt(np.mean(d ** 2, 0) / np.mean(tf ** 2, 0)), d.mean(0), q[e:-e], d


def encoders(model, cutoff, effort="motor"):
    """Axes 1-3: :func:`cosim.identification.encoders.drive_elasticity` of the motor encoder
    (link units) against the link-side encoder, the recorded effort taken as the motor's
    (``effort="motor"``: the model's rotor inertia, friction and offset taken off it) or as the
    transmitted one as recorded (``effort="transmitted"``).  Per
    trajectory and axis: (stiffness [N m/rad], backlash [rad], RMS of the difference, of the
    fit's residual [rad])."""
    out = {}
    for t in "ABC":
        r = scipy.io.loadmat(str(DATA / f"kr300_{t}.mat"), squeeze_me=True, struct_as_record=False)["rec"]
        rec = to_recording(str(DATA / f"kr300_{t}.mat"), str(DATA / "kr300_map.toml"))
        link = np.radians(r.act_pos_se_deg.T) + np.radians([0, -90, 90, 0, 0, 0])
        est = drive_elasticity(model, rec.time, rec.q, link, rec.qd, rec.tau, joints=[1, 2, 3], effort=effort,
                               cutoff=cutoff)
        out[t] = [(e["stiffness"], e["backlash"], e["rms_difference"], e["rms_residual"]) for e in est]
    return out


def counterbalance_torque(q2):
    """The repository's hydraulic counterbalance (ident_functions/hydraulic_weight_counterbalance.m)
    at the model's q2 [rad] (its angle_ax_2 is the recorded angle, q2 + 90 deg, in rad) [N m]."""
    D, k = 0.8, 0.2
    area = np.pi * (0.055 ** 2 - 0.030 ** 2) / 4
    delta = (q2 + np.pi / 2) + np.radians(95)
    dl = np.sqrt(D ** 2 + k ** 2 - 2 * D * k * np.cos(delta)) - (D - k)
    h = np.sin(delta) * D * k / (dl + D - k)
    press = 1.01 * 296.8 * 328 * 2 * 0.0795 / (2 * 0.00048 - dl * area)
    return h * press * area


def figure(path, resid, cutoff):
    """Axis 2's held-out effort error of the identified rigid model (its constant offset
    included) against q2, with the repository's counterbalance torque less its mean over the
    same samples."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.2))
    for t, (q, d) in resid.items():
        ax.plot(np.degrees(q[:, 1]), -d[:, 1], ".", ms=2, label=f"trajectory {t}: recorded - identified model")
    qq = np.concatenate([q[:, 1] for q, _ in resid.values()])
    g = np.linspace(qq.min(), qq.max(), 200)
    ref = counterbalance_torque(g)
    ax.plot(np.degrees(g), ref - np.mean(counterbalance_torque(qq)), "k-",
            label="repository's counterbalance model, less its mean")
    ax.set_xlabel("q2 [deg] (model coordinates: recorded angle - 90 deg)")
    ax.set_ylabel("axis 2 effort [N m]")
    ax.set_title(f"KR300 axis 2: recorded - rigid model identified on A ({cutoff} Hz low-pass)", fontsize=10)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def counterbalance(ident, recs, resid, cutoff):
    """Axis 2's missing torque as a line in q2, fitted on A's residual only: its slope beside the
    repository's counterbalance model's over the same angles; then the identified model with it
    (``joint[2].force_k1`` about ``force_qc``, the line's level in the offset) judged on B and C."""
    q2, miss = resid["A"][0][:, 1], -resid["A"][1][:, 1]
    slope, level = np.polyfit(q2 - q2.mean(), miss, 1)
    ref = np.polyfit(q2, counterbalance_torque(q2), 1)[0]
    allq = np.concatenate([resid[t][0][:, 1] for t in "ABC"])
    ref_all = np.polyfit(allq, counterbalance_torque(allq), 1)[0]
    print(f"\naxis 2 missing torque on A: {slope:.0f} N m/rad x (q2 - {np.degrees(q2.mean()):.1f} deg) "
          f"+ {level:.0f} N m; the repository's counterbalance: slope {ref:.0f} N m/rad over A's angles, "
          f"{ref_all:.0f} over A, B, C's")
    m = ident.model(ROBOT)
    base = m.inverse_dynamics(m.home(), np.zeros(6), np.zeros(6))
    m.set_params({"joint[2].force_qc": float(q2.mean()), "joint[2].force_k1": 1.0})
    probe = m.inverse_dynamics(m.home(), np.zeros(6), np.zeros(6)) - base  # the core's sign of force_k1 in tau
    sign = np.sign(probe[1] / (m.home()[1] - q2.mean()))
    m.set_params({"joint[2].force_k1": float(sign * slope),
                  "joint[2].offset": ident.params["joint[2].offset"] + float(level)})
    for t in "BC":
        _row(f"{t}: identified + axis-2 line [%]", held_out(m, recs[t], cutoff)[0])


def diagnosed(ident_path, recs, cutoff, out):
    """``cosim diagnose`` of B and of C with the identified model as nominal (the command line, as
    a user runs it); the fitted parameters of each (diagnosis.json's theta) added to the identified
    model and judged on the other trajectory; and the engine's own held-out figures (each
    recording's last 30 %)."""
    import json
    import subprocess

    from cosim.recording import write_recording

    base = {k: v["value"] for k, v in json.loads(Path(ident_path).read_text())["parameters"].items()}
    theta = {}
    for t in "BC":
        csv, _ = write_recording(Path(out) / f"kr300_{t}.csv", recs[t])
        d = Path(out) / f"diagnosis_{t}"
        subprocess.run([sys.executable, "-m", "cosim", "--quiet", "diagnose", str(csv), "--model", str(ident_path),
                        "--out", str(d), "--no-figures"], check=True, capture_output=True, cwd=REPO)
        res = json.loads((d / "diagnosis.json").read_text())
        theta[t] = res["theta"]
        h = res["heldout"]["channels"]
        _row(f"{t} last 30 %: before diagnosis [%]", [100 * h[f"tau{i}"]["nrmse_before"] for i in range(1, 7)])
        _row(f"{t} last 30 %: after diagnosis [%]", [100 * h[f"tau{i}"]["nrmse_after"] for i in range(1, 7)])
        print(f"  {t}: {res['conclusion'][:160]}...")
        for f in res.get("encoders", []):  # the link-side encoders of axes 1-3 (q_link1..3)
            print(f"  {t} encoders: {f['statement']}")
    for src, dst in (("B", "C"), ("C", "B")):
        m = Model(ROBOT, params={**base, **theta[src]})
        _row(f"{dst}: identified + diagnosed on {src} [%]", held_out(m, recs[dst], cutoff)[0])


def open_loop(models, recs, windows=(0.1, 0.5)):
    """The open-loop replay (cosim.discrepancy.open_loop, multiple shooting) of B and C: the
    recorded link efforts applied to the core plant of each model, each window started again from
    the recorded state; per axis the rate error RMS over the recorded rates' RMS [%] and the
    position error RMS [mrad], over the whole trajectory (at most 20 windows, spread evenly)."""
    from cosim.discrepancy.open_loop import open_loop_replay

    for w in windows:
        for t in "BC":
            out = open_loop_replay(recs[t], dict(models), window=w)
            print(f"  {t}: {out['method']}")
            for name, r in out["runs"].items():
                if "error" in r:
                    print(f"  {t} {name}: stopped: {r['error']}")
                    continue
                _row(f"{t} {w:g} s: {name} rate [%]", 100 * np.asarray(r["rel_qd"]))
                _row(f"{t} {w:g} s: {name} pos [mrad]", 1e3 * np.asarray(r["rms_q"]), "{:8.2f}")


def _row(label, vals, fmt="{:8.1f}"):
    print(f"{label:34s}" + " ".join(fmt.format(v) for v in vals))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cutoff", type=float, default=2.0, help="low-pass cut-off [Hz] (default 2)")
    ap.add_argument("--figure", default=str(REPO / "docs" / "figures" / "kuka_counterbalance.png"))
    ap.add_argument("--out", default=str(REPO / "out" / "kuka"), help="where the identified model's JSON goes")
    ap.add_argument("--no-diagnose", action="store_true", help="skip cosim diagnose of B and C (about 1 min)")
    a = ap.parse_args(argv)
    recs, p = recordings(), para()
    ident = identify(recs["A"], ROBOT, cutoff=a.cutoff, strict=False)
    path = ident.write(Path(a.out) / "kr300_identified_A.json", ROBOT)
    print(f"identified on A: {len(ident.names)} base parameters of {len(ident.base.standard)} standard, "
          f"{ident.samples} samples, consistent-fit cost {ident.gap:.3g} (0.1 % bound {ident.gap_bound:.3g}); {path}")
    _row("fit on A: residual / RMS [%]", 100 * ident.sigma / ident.rms)
    models = {"nominal (set para)": Model(ROBOT, "para"), "identified on A": ident.model(ROBOT)}
    resid = {}
    for t in "BC":
        for label, m in models.items():
            err, mean, q, d = held_out(m, recs[t], a.cutoff)
            _row(f"{t}: {label} [%]", err)
            _row(f"{t}: {label} mean error [N m]", mean, "{:8.0f}")
            if label.startswith("identified"):
                resid[t] = (q, d)
    print("\ndrive terms, link side: identified on A (+- se) | para")
    pv = ident.params
    se = dict(zip(ident.names, ident.se))
    for j in range(6):
        i = j + 1
        print(f"axis {i}: viscous {pv[f'joint[{i}].viscous']:7.0f} +-{se.get(f'joint[{i}].viscous', np.nan):5.0f}"
              f" | f_vis {p['f_vis'][j]:6.0f};  Coulomb {pv[f'joint[{i}].coulomb']:6.1f} "
              f"+-{se.get(f'joint[{i}].coulomb', np.nan):5.1f} | f_coul + f_a {p['f_coul'][j] + p['f_a'][j]:6.1f};"
              f"  offset {pv[f'joint[{i}].offset']:7.1f} +-{se.get(f'joint[{i}].offset', np.nan):6.1f}"
              f" | f_asym {p['f_asym'][j]:7.1f};  rotor {pv[f'joint[{i}].rotor_inertia']:6.1f} | J_mr u^2 "
              f"{p['J_mr'][j] * p['u'][j] ** 2:6.1f}")
    for effort in ("motor", "transmitted"):
        print(f"\nmotor - link encoders, axes 1-3, effort={effort} (stiffness [N m/rad], backlash [rad], RMS diff, "
              "RMS residual [rad])")
        for t, rows in encoders(models["identified on A"], a.cutoff, effort).items():
            for j, (k, bl, rms, res) in enumerate(rows):
                print(f"{t} axis {j + 1}: stiffness {k:10.4g} | c_rad {p['c_rad_ff'][j]:9.4g};  backlash {bl:10.3g} | "
                      f"q_back {p['q_back'][j]:.3g};  diff RMS {rms:.3g}, residual {res:.3g}")
    print("\nopen-loop replay (recorded efforts in, motion out), multiple shooting")
    open_loop(models, recs)
    if not a.no_diagnose:
        print("\ncosim diagnose with the identified model as nominal")
        diagnosed(path, recs, a.cutoff, a.out)
    resid["A"] = held_out(models["identified on A"], recs["A"], a.cutoff)[2:]
    counterbalance(ident, recs, resid, a.cutoff)
    figure(a.figure, {t: resid[t] for t in "ABC"}, a.cutoff)
    print(f"\nfigure: {a.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
