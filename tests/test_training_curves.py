"""Training curves: curves.csv records -> figure data (swimrl.analysis.training_curves)."""

from __future__ import annotations

import numpy as np

from swimrl.analysis.training_curves import main, plot_training_curves, read_curves


def _write(path, rows):
    path.write_text("frames,eval/R_hat,eval/R_hat_sem,policy/std\n" + "\n".join(rows) + "\n")
    return path


def test_curves_are_read_and_drawn(tmp_path):
    a = _write(tmp_path / "a.csv", ["0,0.2,0.01,1", "100,,,0.9", "200,0.5,0.02,0.8"])
    run = tmp_path / "run"
    run.mkdir()
    _write(run / "curves.csv", ["0,0.25,0.01,1", "200,0.45,0.01,0.7"])
    c = read_curves(a)
    assert np.isnan(c["eval/R_hat"][1]) and c["policy/std"][1] == 0.9
    drawn = plot_training_curves({"a": a, "b": run}, tmp_path / "f.png", references={"STO": 0.5})
    assert (tmp_path / "f.png").stat().st_size > 0
    np.testing.assert_array_equal(drawn["a"][0], [0, 200])  # empty cells are skipped
    np.testing.assert_array_equal(drawn["a"][1], [0.2, 0.5])
    np.testing.assert_array_equal(drawn["b"][1], [0.25, 0.45])
    drawn = plot_training_curves({"a": a}, tmp_path / "s.png", tag="policy/std")
    np.testing.assert_array_equal(drawn["a"][1], [1, 0.9, 0.8])
    main([str(tmp_path / "m.png"), f"x (lr=3e-3)={a}", "--reference", "STO=0.5"])
    assert (tmp_path / "m.png").is_file()
