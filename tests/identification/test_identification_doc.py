"""The first shell example of docs/identification.md runs as written (import two shipped KUKA
trajectories, identify on one, diagnose the other against the identified model)."""
import os
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_the_pages_shell_example_runs(tmp_path):
    page = (REPO / "docs" / "identification.md").read_text()
    block = re.findall(r"```bash\n(.*?)```", page, flags=re.S)[0]
    cmds = [c.split("#")[0].strip() for c in block.splitlines() if c.strip()]
    assert [c.split()[1] for c in cmds] == ["import", "import", "identify", "diagnose"]
    for d in ("data", "robots"):
        (tmp_path / d).symlink_to(REPO / d)
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "TQDM_DISABLE": "1", "MPLBACKEND": "Agg"}
    for c in cmds:
        p = subprocess.run(c, shell=True, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, f"{c}: exit {p.returncode}\n{p.stderr[-2000:]}"
    ident = tmp_path / "out" / "kuka" / "kr300_identified.json"
    assert ident.stat().st_size > 0
    assert "kr300_B.csv (kr300):" in p.stdout  # the diagnosis of B printed its conclusion
