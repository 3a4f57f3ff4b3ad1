"""tmakit.io seams: the format registry, the one atomic-write helper and the one table writer."""

from __future__ import annotations

import os

import numpy as np
import pandas as pd
import pytest

import tmakit as tk
from tmakit.io import (
    Format,
    MeasurementFileError,
    atomic_write,
    find_format,
    read_measurements,
    register_format,
    registered_formats,
    unregister_format,
    write_measurements,
    write_table,
)
from tmakit.io.csv_file import read_csv, write_csv


def small_set() -> tk.MeasurementSet:
    n = 4
    return tk.MeasurementSet(np.arange(n, dtype=float), ["s"] * n, ["bearing"] * n,
                             [10.0, 20.0, 30.0, 40.0], [1.0] * n, np.zeros((n, 6)),
                             metadata={"scenario": "tiny"})


def test_builtin_formats_are_registered_by_name_and_suffix():
    assert {"csv", "parquet", "rep", "wide"} <= {f.name for f in registered_formats()}
    assert find_format("a.rep").name == find_format("a.DSF").name == "rep"
    assert find_format("a.CSV").name == "csv"
    assert find_format("a.pq").name == "parquet"
    assert find_format("a.txt") is None
    with pytest.raises(ValueError, match="unknown measurement file format 'kml'"):
        find_format("a.csv", "kml")


def test_a_new_format_is_one_registration(tmp_path):
    """A format registered under a new suffix is read and written through the registry."""
    register_format(Format("tsvish", "TSV-ish", (".tsvish",), read_csv, write_csv))
    try:
        _use_new_format(tmp_path)
    finally:
        unregister_format("tsvish")
    assert find_format("obs.tsvish") is None


def _use_new_format(tmp_path):
    path = write_measurements(small_set(), tmp_path / "obs.tsvish")
    assert read_measurements(path).equals(small_set())
    with pytest.raises(MeasurementFileError,
                       match=r"\.tsvish \(CSV, Debrief replay, Parquet, .* or TSV-ish\)"):
        read_measurements(tmp_path / "obs.txt")
    with pytest.raises(ValueError, match="registered already"):
        register_format(Format("csv", "CSV", (".csv2",)))
    with pytest.raises(ValueError, match="belongs to the format 'csv'"):
        register_format(Format("other", "Other", (".csv",)))


def test_explicit_format_wins_over_the_suffix(tmp_path):
    path = write_measurements(small_set(), tmp_path / "obs.dat", format="parquet")
    assert path.read_bytes()[:4] == b"PAR1"
    assert read_measurements(path, format="parquet").equals(small_set())
    with pytest.raises(MeasurementFileError, match="unsupported file type"):
        read_measurements(path)


def test_atomic_write_replaces_or_refuses_and_cleans_up(tmp_path):
    path = tmp_path / "f.txt"
    with atomic_write(path) as tmp:
        tmp.write_text("one")
    assert path.read_text() == "one"
    with pytest.raises(FileExistsError, match="force=True"):
        with atomic_write(path):
            pass
    with pytest.raises(RuntimeError):
        with atomic_write(path, force=True) as tmp:
            tmp.write_text("half")
            raise RuntimeError("boom")
    assert path.read_text() == "one" and os.listdir(tmp_path) == ["f.txt"]
    with pytest.raises(IsADirectoryError):
        with atomic_write(tmp_path, force=True):
            pass


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".pq"])
def test_write_table_round_trips_and_names_what_it_writes(tmp_path, suffix):
    frame = pd.DataFrame({"run": np.arange(3), "x": [0.1, np.nan, 1e-300]})
    path = write_table(tmp_path / f"t{suffix}", frame, parquet_metadata={"tmakit:k": "v"})
    back = pd.read_csv(path) if suffix == ".csv" else pd.read_parquet(path)
    pd.testing.assert_frame_equal(back, frame)
    with pytest.raises(FileExistsError):
        write_table(path, frame)
    with pytest.raises(ValueError, match=r"a track is written as \.csv or \.parquet, not \.txt"):
        write_table(tmp_path / "t.txt", frame, what="a track")


def test_an_option_of_another_format_is_refused_naming_it_and_the_format_s_own(tmp_path):
    rep = os.path.join(os.path.dirname(__file__), "data", "debrief", "multistatics",
                       "Vessel_with_Sensor_Offset_first_8_min.rep")
    with pytest.raises(TypeError, match=r"Debrief replay files take no option mapping, "
                                        r"measurements \(they take ownship, contact, "
                                        r"bearing_sigma_deg"):
        read_measurements(rep, mapping="nothing.toml", measurements="x.csv")
    with pytest.raises(TypeError, match=r"GPX files take no option contact \(they take "
                                        r"measurements, mapping, dim\)"):
        (tmp_path / "track.gpx").write_text("<gpx></gpx>")
        read_measurements(tmp_path / "track.gpx", contact="TA")


def test_tma_refuses_an_option_of_another_format_naming_the_flag_and_the_file():
    from typer.testing import CliRunner

    from tmakit.cli import app

    rep = os.path.join(os.path.dirname(__file__), "data", "debrief", "multistatics",
                       "Vessel_with_Sensor_Offset_first_8_min.rep")
    out = CliRunner().invoke(app, ["estimate", rep, "--mapping", "x.toml"])
    assert out.exit_code == 2
    assert "--mapping applies to other formats, not to Debrief replay files" in out.output
    assert "Vessel_with_Sensor_Offset_first_8_min.rep" in out.output
    assert "internal error" not in out.output
