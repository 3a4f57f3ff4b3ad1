"""`tma import wide FILE --guess`: a mapping proposed from a real log's header (issue 26)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

import tmakit as tk
from tmakit.cli import app
from tmakit.io.log_mapping import guess_mapping, load_mapping

SAMPLES = Path(tk.__file__).parent / "examples"
EPOCH = pd.Timestamp("1970-01-01", tz="UTC")


def _drone() -> pd.DataFrame:
    return pd.read_csv(SAMPLES / "drone.csv")


def _epoch(log: pd.DataFrame, unit: str) -> pd.Series:
    per = {"s": pd.Timedelta(seconds=1), "ms": pd.Timedelta(milliseconds=1),
           "us": pd.Timedelta(microseconds=1)}[unit]
    return (pd.to_datetime(log["utc"]) - EPOCH) / per


#: Headers as real logs write them: (columns by the sample log's, the time column and unit,
#: the roles the proposal must find).
LOGS = {
    "PX4 vehicle_gps_position": (
        {"lat": "latitude_deg", "lon": "longitude_deg", "alt_m": "altitude_msl_m",
         "vn": "vel_n_m_s", "ve": "vel_e_m_s", "vd": "vel_d_m_s", "rssi_dbm": "rssi_dbm",
         "freq_hz": "freq_hz"}, ("time_utc_usec", "us")),
    "ArduPilot-like": (
        {"lat": "Lat", "lon": "Lng", "alt_m": "Alt", "vn": "VelN", "ve": "VelE", "vd": "VelD",
         "rssi_dbm": "RSSI", "freq_hz": "Freq"}, ("timestamp", "ms")),
    "generic": (
        {"lat": "latitude", "lon": "longitude", "alt_m": "altitude", "vn": "vel_n",
         "ve": "vel_e", "vd": "vel_d", "rssi_dbm": "rssi", "freq_hz": "frequency_hz"},
         ("epoch", "s")),
}


@pytest.mark.parametrize("name", list(LOGS))
def test_a_guessed_mapping_reads_a_real_log_as_the_hand_written_one(tmp_path, name):
    renames, (time_column, unit) = LOGS[name]
    log = _drone()
    flight = log.rename(columns=renames).drop(columns=["utc"])
    flight.insert(0, time_column, _epoch(log, unit).round().astype("int64")
                  if unit != "s" else _epoch(log, unit))
    path = tmp_path / "flight.csv"
    flight.to_csv(path, index=False)
    guess = guess_mapping(path)
    assert guess.columns["time"] == time_column and guess.time_unit == unit
    assert {guess.columns[r] for r in ("lat", "lon", "alt", "north", "east", "down")} == {
        renames[c] for c in ("lat", "lon", "alt_m", "vn", "ve", "vd")}
    assert guess.columns["power"] == renames["rssi_dbm"]
    assert guess.columns["frequency"] == renames["freq_hz"]
    toml = tmp_path / "guess.toml"
    toml.write_text(guess.toml("flight.csv"))
    mapping = load_mapping(toml)
    mine = tk.read_measurements(path, format="wide", mapping=mapping)
    hand = tk.read_measurements(SAMPLES / "drone.csv", format="wide",
                                mapping=SAMPLES / "drone.toml")
    assert np.allclose(np.sort(mine.time), np.sort(hand.time), atol=1e-3)
    assert sorted(mine.kinds) == sorted(hand.kinds)


def test_the_command_prints_the_proposal_and_refuses_a_header_it_cannot_read(tmp_path):
    runner = CliRunner()
    done = runner.invoke(app, ["import", "wide", str(SAMPLES / "drone.csv"), "--guess"])
    assert done.exit_code == 0, done.output
    assert 'time = "utc"' in done.output and 'frame = "ned"' in done.output
    odd = tmp_path / "odd.csv"
    odd.write_text("a,b,c\n1,2,3\n")
    refused = runner.invoke(app, ["import", "wide", str(odd), "--guess"])
    assert refused.exit_code == 2 and "no time column among a, b, c" in refused.output
    assert runner.invoke(app, ["import", "rep", str(odd), "--guess"]).exit_code == 2
    out = tmp_path / "obs.parquet"  # -o was left unwritten without a word
    told = runner.invoke(app, ["import", "wide", str(SAMPLES / "drone.csv"), "--guess", "-o",
                               str(out)])
    assert told.exit_code == 2 and "--guess only prints a mapping and imports nothing" in (
        " ".join(told.output.split())) and not out.exists()


def test_a_parquet_log_written_with_its_time_as_index_is_guessed_with_it(tmp_path):
    """pd.read_parquet made df.set_index("utc")'s time the index: 'no time column among ...'."""
    path = tmp_path / "drone.parquet"
    pd.read_csv(SAMPLES / "drone.csv").set_index("utc").to_parquet(path)
    assert guess_mapping(path).columns["time"] == "utc"
