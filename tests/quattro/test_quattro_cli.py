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


def test_cycle_writes_the_fitted_model_csv_with_held_out_tables_marked(tmp_path, capsys):
    import csv

    assert main(["quattro", "cycle", "--out", str(tmp_path), "--n", "60", "--fit", "6.1"]) == 0
    rows = list(csv.DictReader(open(tmp_path / "quattro_cycle_model.csv")))
    assert list(rows[0]) == ["table", "layout", "cycle", "z_mm", "measured_s", "torque_limited_s", "model_s",
                             "used_for_fit"]
    assert len(rows) == 61
    assert {r["table"] for r in rows if r["used_for_fit"] == "1"} == {"6.1"}
    assert "table 6.5 (held out)" in capsys.readouterr().out


def test_cycle_fit_on_an_unknown_table_is_one_line(tmp_path, capsys):
    assert main(["quattro", "cycle", "--out", str(tmp_path), "--n", "20", "--fit", "9.9"]) == 2
    assert "fit table '9.9' is not among the measured tables" in capsys.readouterr().err
