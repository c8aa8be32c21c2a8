"""Every robot's plant and controller FMUs on every platform the build makes binaries for:
the PD step of tests/fmu/platform_host.py (steps, state save / restore, a refused NaN effort)
through the tests' FMI 2.0 host, natively (linux64), under Wine (win64) and under QEMU
(aarch64-linux), each against linux64; the FMI 3.0 FMUs through the FMI 3.0 host on the three
platforms against the same FMI 2.0 linux64 run; and the size of each platform's binary.

    .venv/bin/python bench/fmu_platforms.py            # all robots with FMUs (a few minutes)
    .venv/bin/python bench/fmu_platforms.py 6pus quattro

The suite runs the same comparison on two robots (tests/fmu/test_platforms.py).
"""
import sys
import tempfile
import time
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests" / "fmu"))

from platform_host import PLATFORMS, as_fmi3, fmu_pair, largest_difference, loop_script, run  # noqa: E402

from cosim import fmu  # noqa: E402


def robots_with_fmus():
    listed = (REPO / "robots" / "robots.list").read_text().splitlines()  # "6pus" and "quattro" among them
    return [n.split("#")[0].strip() for n in listed if n.split("#")[0].strip()]


def binary_sizes(path):
    """Compressed size in the archive of each platform's binary [bytes]."""
    out = {}
    with zipfile.ZipFile(path) as z:
        for i in z.infolist():
            parts = i.filename.split("/")
            if len(parts) == 3 and parts[0] == "binaries" and parts[2]:
                out[parts[1]] = i.compress_size
    return out


def main(robots):
    print(f"| robot | {' | '.join(p + ' [s]' for p in PLATFORMS)} | largest difference to linux64 | "
          f"same messages | FMI 3.0 on the 3 platforms: largest difference, same messages | "
          f"plant binary in the .fmu, {' / '.join(PLATFORMS)} [kB] |")
    print("| --- " * (len(PLATFORMS) + 5) + "|")
    worst = 0.0
    for robot in robots:
        with tempfile.TemporaryDirectory() as d:
            folder = Path(d)
            plant, ctrl = fmu_pair(robot, folder)
            outs, secs = {}, {}
            for p in PLATFORMS:
                t0 = time.perf_counter()
                outs[p] = run(p, loop_script(plant, ctrl, robot, p), folder)
                secs[p] = time.perf_counter() - t0
            diff = max(largest_difference(outs["linux64"], outs[p]) for p in PLATFORMS[1:])
            same = all(outs[p]["lines"] == outs["linux64"]["lines"] for p in PLATFORMS[1:])
            plant3, ctrl3 = fmu_pair(robot, folder, fmi=3)
            outs3 = {p: run(p, loop_script(plant3, ctrl3, robot, p), folder, fmi=3) for p in PLATFORMS}
            diff3 = max(largest_difference(outs["linux64"], outs3[p]) for p in PLATFORMS)
            same3 = all(outs3[p]["lines"] == as_fmi3(outs["linux64"]["lines"]) for p in PLATFORMS)
            worst = max(worst, diff, diff3)
            sizes = binary_sizes(fmu.fmu_path(robot))
            print(f"| {robot} | {' | '.join(f'{secs[p]:.1f}' for p in PLATFORMS)} | {diff:.1e} | "
                  f"{'yes' if same else 'NO'} | {diff3:.1e}, {'yes' if same3 else 'NO'} | "
                  f"{' / '.join(str(round(sizes.get(p, 0) / 1024)) for p in PLATFORMS)} |")
    print(f"\nlargest difference over all robots: {worst:.1e} (bound 1e-12)")
    return 0 if worst <= 1e-12 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:] or robots_with_fmus()))
