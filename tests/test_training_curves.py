"""Training curves: curves.csv records -> figure data (swimrl.analysis.training_curves)."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_curves_over_a_base(tmp_path):
    """write_curves: the event files' rows over ``base`` (the rows a resumed run kept from its
    committed CSV; a step in both keeps the event files' row); without a base, only the event
    files, whatever an older CSV held."""
    import csv

    from torch.utils.tensorboard import SummaryWriter

    from swimrl.runs.curves import read_curves_csv, write_curves

    out = tmp_path / "curves.csv"
    out.write_text("frames,eval/R_hat,train/R_hat\n100,0.25,\n200,,0.3\n300,,0.4\n")
    base = read_curves_csv(out)
    writer = SummaryWriter(str(tmp_path / "tb" / "ppo"))
    for step, value in ((300, 0.45), (400, 0.5)):
        writer.add_scalar("train/R_hat", value, step)
    writer.close()
    write_curves(tmp_path)
    assert sorted(read_curves_csv(out)) == [300, 400]  # no base: the stale rows are gone
    write_curves(tmp_path, base=base)
    rows = read_curves_csv(out)
    assert sorted(rows) == [100, 200, 300, 400]
    assert rows[100] == {"eval/R_hat": 0.25} and rows[200] == {"train/R_hat": 0.3}
    assert rows[300]["train/R_hat"] == pytest.approx(0.45) and rows[400]["train/R_hat"] == 0.5
    header = next(csv.reader(out.open()))
    assert header[0] == "frames" and "time/frames_per_s" in header
