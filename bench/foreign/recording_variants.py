"""The MuJoCo unlisted recordings diagnosed again with less in them: what another simulator's
recordings may lack.

    .venv/bin/python bench/foreign/recording_variants.py --set /work/wt/recordings/set11_43700
        [--variants recorded,no_qref,no_qd,qd_derived,no_pose,500hz] [--cases magnet_43701,...]
        [--out results/recording_variants]

The recordings of ``bench/foreign/mujoco_unlisted.py`` (its ``--out`` directory: a CSV and a
sidecar per case and its ``rows.json``, which holds each case's kind, truth and rail) all carry
a commanded reference (``qref``), measured rates (``qd``), the platform pose (``x .. rz``), at
1 kHz for 8.5 s.  Each variant rewrites every recording before the diagnosis (the defaults,
``diagnose(csv, figures=False, replay=False)``):

* ``recorded``: as recorded;
* ``no_qref``: without the reference columns (docs/recording.md: optional);
* ``no_qd``: without the rate columns, which the format requires: the diagnosis must refuse the
  file in one line naming the column (a refusal is counted, not a crash);
* ``qd_derived``: the rates derived from the positions by central differences, as
  ``cosim import`` derives them (``derive = "central_difference"``, docs/importing.md);
* ``no_pose``: without the platform pose (optional);
* ``500hz``, ``200hz``: every 2nd or 5th sample, the efforts the mean of the commands held over
  its step (a controller at that rate holds one effort over the step, what the diagnosis reads:
  the f-th 1 kHz command alone, held for 1 ms of the f, reads as the efforts shifted by 0.5 (f - 1) ms);
* ``5s``: the first 5 s only;
* ``bare``: no reference, derived rates, no pose, 500 Hz at once.

Each case is judged as ``mujoco_unlisted.py`` judges it (its :func:`keyed`,
:func:`diagnosed_row`, :func:`_judged`: the flexible stage's inputs against the declaration
fixed with the mechanism; a clean case clean when nothing is found).  Per variant the table
gives: the keyed-on inputs named, a channel explained by the flexible stage, a library effect
named with confidence (a failure: the truth is outside the library), the clean recordings that
stay clean, the errors (any exception other than a refusal of the input, or a non-finite number
in a row: a bug) and the diagnosis CPU.  One process; a set of 17 cases takes about 2 minutes of
CPU per variant at 1 kHz.
"""
from __future__ import annotations

import argparse
import json
import math
import shutil
import sys
import time
import traceback
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

VARIANTS = ("recorded", "no_qref", "no_qd", "qd_derived", "no_pose", "500hz", "200hz", "5s", "bare")
POSE = ("x", "y", "z", "rx", "ry", "rz")


def _read(csv: Path) -> tuple:
    """``(header, table)`` of a recording's CSV."""
    with open(csv) as fh:
        header = fh.readline().strip().split(",")
    return header, np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)


def variant(csv: Path, name: str, out: Path) -> Path:
    """Write the recording ``csv`` (and its sidecar) as the variant ``name`` into ``out``;
    returns the new CSV's path."""
    from cosim.importing.convert import derive

    header, data = _read(csv)
    meta = json.loads(csv.with_suffix(".json").read_text())
    meta.pop("robot_file", None)  # a path relative to the original; the robot is the library's
    keep = list(range(len(header)))
    steps = [name] if name != "bare" else ["no_qref", "qd_derived", "no_pose", "500hz"]
    for step in steps:
        if step == "no_qref":
            keep = [i for i in keep if not header[i].startswith("qref")]
            meta.get("units", {}).pop("qref", None)
        elif step == "no_pose":
            keep = [i for i in keep if header[i] not in POSE]
            meta.get("units", {}).pop("pose", None)
        elif step == "no_qd":
            keep = [i for i in keep if not header[i].startswith("qd")]
        elif step == "qd_derived":
            t = data[:, 0]
            for i, col in enumerate(header):
                if col.startswith("qd") and col[2:].isdigit():
                    data[:, i] = derive(data[:, header.index(f"q{col[2:]}")], t, "central_difference")
                    meta.setdefault("derived", {})[col] = {"from": f"q{col[2:]}", "method": "central_difference"}
        elif step in ("500hz", "200hz"):
            # every f-th sample; the efforts the mean of the 1 kHz commands held over its step, the
            # effort a controller at the lower rate would hold there (Pipeline's zoh reading): the
            # f-th command alone would be held for 1 ms of the f ms, a shift of the efforts
            f = {"500hz": 2, "200hz": 5}[step]
            n = len(data) // f * f
            taus = [i for i, col in enumerate(header) if col.startswith("tau") and col[3:].isdigit()]
            held = data[:n, taus].reshape(n // f, f, len(taus)).mean(axis=1)
            data = data[:n:f]
            data[:, taus] = held
        elif step == "5s":
            data = data[data[:, 0] <= data[0, 0] + 5.0]
        elif step != "recorded":
            raise ValueError(step)
    path = out / csv.name
    np.savetxt(path, data[:, keep], delimiter=",", header=",".join(header[i] for i in keep), comments="",
               fmt="%.17g")
    path.with_suffix(".json").write_text(json.dumps(meta, indent=1))
    return path


def _finite(row, note) -> bool:
    """No NaN or infinity among a row's numbers (its shares, size, CPU), nor a held-out gain
    NaN without the diagnosis's ``note`` saying why none could be measured."""
    nums = [row["cpu"], row["size_over_noise"], row.get("share", 0.0)] + [s for _, s, _ in row["flexible"]]
    gain_told = row["gain"] is None or math.isfinite(row["gain"]) or bool(note)
    return all(math.isfinite(x) for x in nums) and gain_told


def diagnose_case(csv: Path, given: dict) -> dict:
    """The judged row of one recording (``given``: its row in the set's rows.json), or
    ``{"case", "kind", "refused" | "error"}`` where the diagnosis refused the input or failed."""
    import mujoco_unlisted as mu

    from cosim.discrepancy import blind, diagnose
    from cosim.errors import DiagnosisError
    from cosim.recording import RecordingError

    kind, truth = given["kind"], given["truth"]
    key = None if kind == "clean" else mu.keyed(kind, truth.get("rail"), truth.get("other_rail"))
    tau_noise = blind.load_config()["noise"]["6pus"]["tau"]
    t0 = time.process_time()
    try:
        with mu._RuleLog() as rule:
            d = diagnose(str(csv), figures=False, replay=False)
    except (DiagnosisError, RecordingError) as exc:
        return {"case": given["case"], "kind": kind, "refused": str(exc), "cpu": time.process_time() - t0}
    except Exception:  # a crash: a bug to fix
        return {"case": given["case"], "kind": kind, "error": traceback.format_exc(), "cpu": time.process_time() - t0}
    cpu = time.process_time() - t0
    row = mu.diagnosed_row(d, kind, given["seed"], given.get("scale", 1.0), truth, given["joint"], tau_noise, cpu,
                           rule)
    row = mu._judged(row, d.flexible, key)
    if not _finite(row, d.heldout.get("gain_note")):
        row["error"] = "a non-finite number in the row"
    return row


def summary(name: str, rows: list) -> str:
    """One table line of a variant's rows."""
    eff = [r for r in rows if r["kind"] != "clean" and "refused" not in r and "error" not in r]
    clean = [r for r in rows if r["kind"] == "clean" and "refused" not in r and "error" not in r]
    n_eff = sum(r["kind"] != "clean" for r in rows)
    n_clean = sum(r["kind"] == "clean" for r in rows)
    refused = [r for r in rows if "refused" in r]
    errors = [r for r in rows if "error" in r]
    cpu = [r["cpu"] for r in rows]
    # the refusal's reason without the file's path
    ref = f"{len(refused)} ({refused[0]['refused'].split(', ', 1)[-1].splitlines()[0]})" if refused else "0"
    return (f"| {name} | {sum(r['inputs_right'] for r in eff)}/{n_eff} | {sum(bool(r['named']) for r in eff)}/{n_eff} | "
            f"{sum(bool(r['library_confident']) for r in eff)}/{n_eff} | {sum(r['clean'] for r in clean)}/{n_clean} | "
            f"{len(errors)} | {ref} | {np.median(cpu):.1f} / {sum(cpu):.0f} |")


HEAD = ["| variant | keyed-on inputs named | a channel explained | library named with confidence | clean stays "
        "clean | errors (exception or NaN) | refused | CPU per case median / total [s] |", "|---" * 8 + "|"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", type=Path, required=True, help="a mujoco_unlisted.py output directory (rows.json, CSVs)")
    ap.add_argument("--variants", default="recorded,no_qref,no_qd,qd_derived,no_pose,500hz")
    ap.add_argument("--cases", default="", help="comma-separated case names (default: every case of rows.json)")
    ap.add_argument("--out", type=Path, default=REPO / "results" / "recording_variants")
    a = ap.parse_args(argv)
    names = [v for v in a.variants.split(",") if v]
    bad = [v for v in names if v not in VARIANTS]
    if bad:
        ap.error(f"unknown variant(s) {', '.join(bad)}; known: {', '.join(VARIANTS)}")
    if not (a.set / "rows.json").is_file():
        ap.error(f"--set {a.set}: no rows.json (a mujoco_unlisted.py --out directory holds one beside its CSVs)")
    given = json.loads((a.set / "rows.json").read_text())
    want = {c for c in a.cases.split(",") if c}
    given = sorted([g for g in given if not want or g["case"] in want], key=lambda g: (g["kind"] == "clean", g["seed"]))
    lines = []
    for name in names:
        work = a.out / a.set.name / name
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
        rows = []
        for g in given:
            row = diagnose_case(variant(a.set / f"{g['case']}.csv", name, work), g)
            row["variant"] = name
            rows.append(row)
            brief = {k: row.get(k) for k in ("variant", "case", "inputs_right", "named", "library_confident", "clean",
                                              "refused", "error", "cpu")}
            print(json.dumps(brief, default=str), flush=True)
        (work / "rows.json").write_text(json.dumps(rows, indent=1, default=str))
        lines.append(summary(name, rows))
        print("\n".join(HEAD + lines), flush=True)
    print(f"\n{a.set.name}\n" + "\n".join(HEAD + lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
