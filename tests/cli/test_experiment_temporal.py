"""Temporal smoothing on the simulator's walking figure (app.temporal_experiment, `mirrorscan
experiment temporal`): the still parts of the body come closer to the true surface, the moving limbs
are not smeared."""

import numpy as np

from mirrorscan.cli import main
from mirrorscan.experiments.temporal import run_temporal_experiment, summary


def test_the_still_parts_improve_and_the_moving_ones_do_not_smear():
    # 640x480, as the README reports
    rows = run_temporal_experiment(neighbours=2, frames=4, progress=False)
    figures = summary(rows)
    assert [r["part"] for r in rows] == ["still", "moving"] * 4 and min(
        r["points"] for r in rows
    ) > 5000
    assert 3.5 < figures["still"]["rmse_mm"] < 6.0 and 3.5 < figures["moving"]["rmse_mm"] < 6.0
    # `mirrorscan experiment temporal` gives -40 % (2.7 mm against 4.6 mm over 30 frames)
    assert figures["still"]["change_pct"] < -25
    assert figures["moving"]["change_pct"] < 5  # measured: -1 % (no smearing)
    assert all(r["temporal_outliers_pct"] < 0.5 for r in rows)


def test_the_command_writes_its_csv_and_plot(tmp_path, capsys, monkeypatch):
    import mirrorscan.experiments.temporal as experiment

    calls = []

    def small(neighbours, frames, progress):
        calls.append((neighbours, frames))
        return run_temporal_experiment(neighbours, frames, scale=0.5, progress=progress)

    monkeypatch.setattr(experiment, "run_temporal_experiment", small)
    assert (
        main(
            [
                "experiment",
                "temporal",
                "-o",
                str(tmp_path / "t"),
                "--neighbours",
                "1",
                "--frames",
                "2",
                "--quiet",
            ]
        )
        == 0
    )
    assert calls == [(1, 2)]
    out = capsys.readouterr().out
    assert "still parts: RMSE" in out and "--temporal 1" in out
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert (
        lines[0] == "frame,part,points,rmse_mm,temporal_rmse_mm,outliers_pct,temporal_outliers_pct"
    )
    assert len(lines) == 5 and (tmp_path / "t.png").stat().st_size > 10000
    assert np.isfinite([float(x) for x in lines[1].split(",")[3:]]).all()
