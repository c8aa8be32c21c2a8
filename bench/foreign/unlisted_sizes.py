"""The sizes of bench/foreign/mujoco_unlisted.py's mechanisms from the truth alone: no diagnosis.

    .venv/bin/python bench/foreign/unlisted_sizes.py --kinds-set 4 --first-seed 57750 [--sets 2]
        [--kinds end_cushion,...] [--duration 9]

Per case (the kind drawn at the seed ``first seed + the kind's index``, as the bench draws it) two
noise-free MuJoCo runs of the bench's set-up, the mechanism on and off; the size is the recorded
efforts' change, its RMS about its mean (the bench's size is the nominal residual's, whose mean
the library's offsets take) over the 5 mN effort noise, on the most affected channel.  The
recordings are not written and nothing of the engine's diagnosis runs: a set's sizes can be
checked at seeds outside its draws without seeing what the engine makes of them.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]


def truth_size(kind, seed, duration) -> dict:
    """``{"kind", "seed", "size", "channel", "sizes", "truth"}`` of one case: the efforts' RMS
    change about its mean over the effort noise per channel (``sizes``), its largest and where."""
    import mujoco_blind as mb
    import mujoco_unlisted as mu

    from cosim.core import Model
    from cosim.discrepancy import blind

    m = Model("6pus")
    hook, edit, truth, _, _ = mu.draw(kind, np.random.default_rng(seed), m, mu.motion(m, seed))
    noise = blind.load_config()["noise"]["6pus"]
    quiet = {k: (0.0 if np.isscalar(v) else [0.0] * len(v)) for k, v in noise.items()}
    on, _ = mb.simulate(m, None, 0.0, 0, seed, duration, quiet, hook=hook, edit=edit)
    off, _ = mb.simulate(m, None, 0.0, 0, seed, duration, quiet)
    d = np.asarray(on.tau) - np.asarray(off.tau)
    sizes = np.sqrt(np.mean((d - d.mean(axis=0)) ** 2, axis=0)) / noise["tau"]
    if not np.all(np.isfinite(sizes)):
        raise RuntimeError(f"{kind} {seed}: the run with the mechanism is not finite")
    return {"kind": kind, "seed": seed, "size": float(sizes.max()), "channel": int(np.argmax(sizes)) + 1,
            "sizes": sizes.tolist(), "truth": truth}


def main(argv=None) -> int:
    import mujoco_unlisted as mu

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kinds-set", type=int, choices=sorted(mu.KIND_SETS), default=4)
    ap.add_argument("--kinds", default=None, help="comma-separated kinds of the set (default: all)")
    ap.add_argument("--first-seed", type=int, required=True, help="a seed outside the set's draws")
    ap.add_argument("--sets", type=int, default=1, help="seed sets from the first one on, 10 apart")
    ap.add_argument("--duration", type=float, default=9.0, help="MuJoCo run [s] (the bench's 9)")
    a = ap.parse_args(argv)
    order = mu.KIND_SETS[a.kinds_set]
    kinds = order if a.kinds is None else [k for k in a.kinds.split(",") if k]
    bad = [k for k in kinds if k not in order]
    if bad:
        ap.error(f"not kinds of set {a.kinds_set}: {', '.join(bad)}")
    rows = []
    for base in range(a.first_seed, a.first_seed + 10 * a.sets, 10):
        for kind in kinds:
            t0 = time.time()
            r = truth_size(kind, base + order.index(kind), a.duration)
            rows.append(r)
            print(f"{kind:16s} {r['seed']} size {r['size']:6.1f} (tau{r['channel']}) "
                  f"[{' '.join(f'{s:.1f}' for s in r['sizes'])}] {time.time() - t0:.0f} s", flush=True)
    print("\n| kind | seeds | size (RMS / noise) |\n|---|---|---|")
    for kind in kinds:
        rs = [r for r in rows if r["kind"] == kind]
        print(f"| {kind} | {', '.join(str(r['seed']) for r in rs)} | "
              f"{', '.join('%.1f (tau%d)' % (r['size'], r['channel']) for r in rs)} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
