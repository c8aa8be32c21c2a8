"""A single continuous revolute axis for the tests: the bundled pendulum (robots/pendulum.toml)
with its stroke replaced by ``continuous = true`` (docs/robots.md), under another name."""
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def continuous_pendulum(directory, name: str) -> Path:
    """Write ``<directory>/<name>.toml``: the pendulum whose axis is continuous (no limits),
    its robot named ``name``; returns the path."""
    text = (REPO / "robots" / "pendulum.toml").read_text()
    text = text.replace("stroke = [-3.1, 3.1]", "continuous = true").replace('name = "pendulum"', f'name = "{name}"')
    assert "continuous = true" in text and f'name = "{name}"' in text, "robots/pendulum.toml changed its stroke or name"
    path = Path(directory) / f"{name}.toml"
    path.write_text(text)
    return path
