"""The pictures an analyst trusts (issue 12): lat/lon maps with a visible scale bar, clock time."""

from __future__ import annotations

import matplotlib.figure
import numpy as np
import pytest
from sample_logs import replay_sample
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.plot.frame import MapFrame, plot_times

runner = CliRunner()


@pytest.fixture
def figures(monkeypatch):
    """The figures the commands save (each inspected as drawn)."""
    saved = []
    original = matplotlib.figure.Figure.savefig

    def keep(fig, *args, **kwargs):
        saved.append(fig)
        return original(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    return saved


@pytest.fixture
def rep(tmp_path):
    path = tmp_path / "contact.rep"
    path.write_text(replay_sample(0)[0])
    return path


def _scale_bar_km(ax):
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    bars = [a for a in ax.artists if isinstance(a, AnchoredSizeBar)]
    assert len(bars) == 1
    return bars[0]


@pytest.mark.parametrize("command", [
    ["estimate", "--motion", "cv2d", "--bearing-sigma", "0.5"],
    ["track", "--bearing-sigma", "0.5"],
    ["show"],
])
def test_maps_of_a_replay_file_are_in_lat_lon_with_clock_time(tmp_path, rep, figures, command):
    out = runner.invoke(app, [command[0], str(rep), *command[1:], "--plot",
                              str(tmp_path / "p.png")])
    assert out.exit_code == 0, out.output
    (fig,) = figures
    axes = fig.get_axes()
    the_map = next(ax for ax in axes if ax.get_xlabel() == "longitude (deg)")
    assert the_map.get_ylabel() == "latitude (deg)"
    _scale_bar_km(the_map)
    # The legend is under the figure: it hides neither the map's data nor its scale bar.
    assert the_map.get_legend() is None and fig.legends
    time_axes = [ax for ax in axes if ax.get_xlabel().startswith("time")]
    if command[0] != "track":  # track draws error panels only when the truth is known
        assert time_axes and time_axes[-1].get_xlabel() == "time (UTC, 2026-05-04)"
        assert ":" in time_axes[-1].xaxis.get_major_formatter()(time_axes[-1].get_xticks()[1])


def test_a_stationary_emitter_is_not_labelled_with_a_time(tmp_path, figures):
    obs = tmp_path / "s.csv"
    runner.invoke(app, ["simulate", "gu2007", "--seed", "1", "-o", str(obs)])
    out = runner.invoke(app, ["estimate", str(obs), "--motion", "static2d", "--plot",
                              str(tmp_path / "p.png")])
    assert out.exit_code in (0, 1), out.output
    texts = [t.get_text() for ax in figures[0].get_axes() for t in ax.texts]
    assert "emitter (stationary)" in texts and "0 s" not in texts


def test_plot_times_and_map_frame(rep):
    ms = tk.read_measurements(rep)
    when, label = plot_times(ms, np.array([0.0, 90.5]))
    assert label == "time (UTC, 2026-05-04)"
    assert str(when[1]) == "2026-05-04T09:31:30.500"
    frame = MapFrame(ms)
    lon, lat = frame.xy([0.0, 1000.0], [0.0, 0.0])
    assert lat[0] == pytest.approx(47.95) and lon[0] == pytest.approx(-5.25)
    # 1 km east is 1000 m / metres_per_x degrees of longitude; the aspect keeps it true
    assert (lon[1] - lon[0]) * frame.metres_per_x() == pytest.approx(1000.0, rel=1e-3)
    plain = ms.take(np.arange(len(ms)))
    plain.metadata = {}
    assert plot_times(plain, np.array([5.0]))[1] == "time (s)"
    assert MapFrame(plain).labels == ("East (km)", "North (km)")
    # and 1 km north is the aspect's worth of longitude degrees on screen
    _, lat2 = frame.xy([0.0], [1000.0])
    assert (lat2[0] - lat[0]) * frame.aspect() * frame.metres_per_x() == pytest.approx(1000.0,
                                                                                        rel=1e-6)


def test_solution_title_speaks_the_users_units(tmp_path, rep, figures):
    out = runner.invoke(app, ["estimate", str(rep), "--motion", "cv2d", "--units", "nautical",
                              "--bearing-sigma", "0.5", "--plot", str(tmp_path / "p.png")])
    assert out.exit_code == 0, out.output
    title = " ".join(figures[0].get_suptitle().split())
    assert " kn" in title and " nmi, bearing " in title and "m/s" not in title
    assert "lat 47.8" in title and "lon -5.4" in title and "ellipse semi-axes" in title
    legend = [t.get_text() for t in figures[0].legends[0].get_texts()]
    ellipses = next(t for t in legend if "position ellipses" in t)
    assert "hidden by the dots" in ellipses  # 250 m ellipses on a 40 km map: said, not lost


def test_show_of_a_drone_log_plain_ticks_and_power_sigma_in_db(tmp_path, figures):
    from sample_logs import drone_sample

    text, mapping, _ = drone_sample(0)
    log, toml = tmp_path / "drone.csv", tmp_path / "drone.toml"
    log.write_text(text)
    toml.write_text(mapping)
    out = runner.invoke(app, ["show", str(log), "--mapping", str(toml), "--plot",
                              str(tmp_path / "p.png")])
    assert out.exit_code == 0, out.output
    fig = figures[0]
    fig.canvas.draw()
    the_map = next(ax for ax in fig.get_axes() if ax.get_xlabel() == "longitude (deg)")
    assert the_map.yaxis.get_offset_text().get_text() == ""  # 47.955, not +4.795e1
    labels = [t.get_text() for t in the_map.get_yticklabels() if t.get_text()]
    assert all(label.startswith("47.9") for label in labels)
    power = next(ax.get_title() for ax in fig.get_axes() if ax.get_title().startswith("power"))
    assert power.endswith(" dB") and "dBm" not in power
