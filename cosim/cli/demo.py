"""``cosim demo``: the main job of ``./scripts/demo.sh``.

End to end on the 6-PUS: first the PD + gravity-compensation step scenario and, for
comparison, the plain PD one (step metrics, steady-state errors against Kp^-1 g, a
figure and a ``pkm-recording/1`` export of each); then the model-discrepancy demo:
simulate a closed-loop run whose plant hides an effect the nominal model lacks,
diagnose the recording, name the effect with its fitted value, and show the held-out
fit before and after adding it.
"""
from __future__ import annotations

from pathlib import Path

from .common import command, output_dir


def _effect_types():
    """The effect types the blind generator can hide (for --help)."""
    from ..discrepancy.blind import TYPES

    return TYPES

REPO = Path(__file__).resolve().parents[2]
DEMO_SCENARIOS = ("6pus_step_pdg.toml", "6pus_step_pd.toml")


def _configure(p):
    p.add_argument("--out", type=output_dir, default="results/demo", help="output directory (default: results/demo)")
    p.add_argument("--plant", choices=["core", "fmu"], default=None, help="plant (default: the scenario's)")
    p.add_argument("--effect", default="coulomb", help=f"effect hidden in the discrepancy demo (default coulomb): {', '.join(_effect_types())}")
    p.add_argument("--seed", type=int, default=3, help="seed of the discrepancy demo's blind case")


@command("demo", "end-to-end 6-PUS demo: step scenarios, then simulate a hidden effect, diagnose it, show the gain")
def cmd_demo(args):
    import argparse

    from .discrepancy import cmd_discrepancy_demo
    from ..scenario import run_scenario
    from .scenario import print_summary

    out_dir = Path(args.out)
    print("== Part 1: co-simulation scenarios (joint PD controllers closed around the 6-PUS plant; each summary says "
          "which loop ran and the plant's integrator)\n")
    for name in DEMO_SCENARIOS:
        out = run_scenario(REPO / "scenarios" / name, plant=args.plant, out_dir=out_dir)
        print_summary(out)
        print()
    print(f"figures and recordings in {out_dir}/\n")
    print("== Part 2: model discrepancy (a recording whose plant hides an effect)\n")
    return cmd_discrepancy_demo(argparse.Namespace(out=str(out_dir / "discrepancy"), robot="6pus",
                                                   effect=args.effect, seed=args.seed))


cmd_demo.configure = _configure
