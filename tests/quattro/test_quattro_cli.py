"""``cosim quattro ...`` commands end to end (small runs)."""
import json

from cosim.cli import main


def test_map_writes_the_requested_figures(tmp_path, capsys):
    assert main(["quattro", "map", "--out", str(tmp_path), "--index", "alfa_z", "--npz"]) == 0
    assert (tmp_path / "quattro_alfa_z.png").stat().st_size > 10_000
    assert (tmp_path / "quattro_maps.npz").exists()
    assert "22491 poses" in capsys.readouterr().out


def test_maxima_lists_every_stated_feature(capsys):
    assert main(["quattro", "maxima", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["index"] for r in rows] == ["mu_T", "mu_xy", "mu_z_eig", "kat", "alfa_x"]
    for r in rows:
        assert {"stated_mm", "appendix_a", "default"} <= set(r)


def test_bad_parameter_set_is_a_clean_error(tmp_path, capsys):
    assert main(["quattro", "map", "--out", str(tmp_path), "--set", "nope"]) == 2
    assert "appendix_a" in capsys.readouterr().err
