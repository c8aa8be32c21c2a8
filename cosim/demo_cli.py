"""``cosim demo``: the main job of ``./scripts/demo.sh``.

For now a 6-PUS demo: the PD + gravity-compensation step scenario and, for
comparison, the plain PD one, with their step metrics and steady-state errors, a
figure and a ``pkm-recording/1`` export of each.
"""
from __future__ import annotations

from pathlib import Path

from .cli import command

REPO = Path(__file__).resolve().parent.parent
DEMO_SCENARIOS = ("6pus_step_pdg.toml", "6pus_step_pd.toml")


def _configure(p):
    p.add_argument("--out", default="results/demo", help="output directory (default: results/demo)")
    p.add_argument("--plant", choices=["core", "fmu"], default=None, help="plant (default: the scenario's)")


@command("demo", "6-PUS demo: PD+G and PD z-step scenarios, step metrics, figure and recording")
def cmd_demo(args):
    from .scenario import run_scenario
    from .scenario_cli import print_summary

    out_dir = Path(args.out)
    for name in DEMO_SCENARIOS:
        out = run_scenario(REPO / "scenarios" / name, plant=args.plant, out_dir=out_dir)
        print_summary(out)
        print()
    print(f"figures and recordings in {out_dir}/")
    return 0


cmd_demo.configure = _configure
