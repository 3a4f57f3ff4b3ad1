"""Issue 26 figure: public Debrief sample files read as given, and cv2d on each straight leg.

The sample files are in ``tests/data/debrief`` (sources, commits and licences in its README):
Debrief's SATC "Force Protection Scenario" and TA_DUMMY "Narrowband Tracking Scenario" (a
sensor file, the own ship's track and the subject's track each; TA_DUMMY's cuts also with
positions ``NULL`` and three gaps, from a spreadsheet); its S2R "2553" set (the same,
but its sensor file is of another run) and "hover north" set (a hull-mounted and a towed-array
sensor, ambiguous bearings, the tracks in the same file; another run's towed-array file beside
it); its ``sen_ssk_sensor.dsf`` (a submarine's bearings of the frigate); and pepys-import's
copies of Debrief replay files (``bulk_data.rep``: own ship ``MER`` holding 7 of 20 fishing
vessels whose tracks are in the file; the frigate's sensor file of 5 sensors on the submarine,
with the track file of both; a frequency file; a track file; a mixed test file with ambiguous
bearings).

1. **Every file read.**  Each file is parsed, and each of its own ships' sensors is read as
   ``tma`` reads it (with the file's track file beside it where its positions are ``NULL``),
   with no option but ``--ownship`` and ``--contact`` (a sensor's name).  A file is *read* when
   none of this is refused; the notes and warnings tmakit prints are counted.
2. **Each straight leg of each subject** (from its truth track: a run of fixes of one course
   and speed, 3 fixes or more, with at least :data:`MIN_CUTS` cuts in it) is fitted as

       tma estimate SENSOR_FILE TRACK_FILE --motion cv2d --kinds bearing,range \
           --from START --to END

   (bearings, and ranges where they are measurements: placeholder ranges are left out by the
   reader; default sigmas).  Course and speed at the leg's last cut are compared with the
   truth: *within* 2 deg and 0.3 kn; *unobservable* (tmakit's status, with its reason);
   *undetermined* (converged, but the course or speed left out of the answer with an
   ``undetermined`` warning: its 1-sigma is too wide to print it as a number); *uncertain*
   (not within, but the truth inside the printed course and speed +- 1.96 std:
   not wrong, yet printed as numbers with no word that they are undetermined); or *off* (a
   confident miss: printed as such, never rounded).  A sample set whose truth track is not
   the truth of its cuts (their median bearing more than :data:`TRUTH_MISMATCH_DEG` from the
   truth's) is said so, and its legs are not fitted.

    python benchmarks/debrief_samples.py
"""

from __future__ import annotations

import argparse
import lzma
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import tmakit as tk
from tmakit.core.geodesy import geodetic_to_enu
from tmakit.io.debrief import replay_tracks
from tmakit.io.errors import reader_notes
from tmakit.io.logs import KNOT, iso_utc

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "debrief"
#: A leg needs at least this many cuts to be fitted.
MIN_CUTS = 6
#: Within: course error (deg) and speed error (kn).
COURSE_TOL_DEG, SPEED_TOL_KN = 2.0, 0.3
#: A sample set whose cuts' median bearing differs from its truth track's by more (deg) is not a
#: truth case (its sensor file and its tracks come from different runs).
TRUTH_MISMATCH_DEG = 5.0
#: The two-sided 95 % normal quantile: a leg's truth within this many stds is inside the answer.
Z95 = 1.959964
#: The verdicts on a fitted leg, in the order they are counted.
VERDICTS = ("within", "unobservable", "undetermined", "uncertain", "off")
#: The kinds fitted on a leg.
KINDS = ("bearing", "range")
#: Each sensor file and the track files read with it (``tma`` takes them together).
COMPANIONS = {"satc/BlueSensor_sparse.rep": ["satc/BlueTrack.rep"],
              "ta_dummy/Freq_BlueSensor.rep": ["ta_dummy/Freq_BlueTrack.rep"],
              "ta_dummy/Freq_BlueSensor_NoPos.dsf": ["ta_dummy/Freq_BlueTrack.rep"],
              "pepys/sen_frig_sensor.dsf": ["pepys/sen_tracks.rep"],
              "pepys/sen_ssk_freq.dsf": ["pepys/sen_tracks.rep"],
              "s2r_2553/BlueSensorBrg.dsf": ["s2r_2553/BlueTrack.rep"],
              "sen/sen_ssk_sensor.dsf": ["pepys/sen_tracks.rep"],
              "s2r_hover_north/Ambig_tracks_hover_north_TA.dsf": [
                  "s2r_hover_north/Ambig_tracks_hover_north.rep"],
              "asset_ambig/Ambig_cuts_TA.rep": ["asset_ambig/Ambig_tracks2.rep"],
              "asset_ambig/Ambig_cuts_HM.rep": ["asset_ambig/Ambig_tracks2.rep"]}


@dataclass(frozen=True)
class SampleSet:
    """A sensor file (with its track files), the own ship, the contact and its truth track."""

    name: str
    files: tuple[str, ...]
    truth_file: str
    subject: str
    ownship: str | None = None
    contact: str | None = None


SETS = [SampleSet("SATC Force Protection", ("satc/BlueSensor_sparse.rep", "satc/BlueTrack.rep"),
                  "satc/RedTrack.rep", "SUBJECT"),
        SampleSet("TA_DUMMY narrowband", ("ta_dummy/Freq_BlueSensor.rep",
                                          "ta_dummy/Freq_BlueTrack.rep"),
                  "ta_dummy/Freq_RedTrack.rep", "SUBJECT"),
        SampleSet("TA_DUMMY NoPos", ("ta_dummy/Freq_BlueSensor_NoPos.dsf",
                                     "ta_dummy/Freq_BlueTrack.rep"),
                  "ta_dummy/Freq_RedTrack.rep", "SUBJECT"),
        SampleSet("S2R 2553 narrowband", ("s2r_2553/BlueSensorBrg.dsf", "s2r_2553/BlueTrack.rep"),
                  "s2r_2553/RedTrack.rep", "SUBJECT"),
        *(SampleSet(f"S2R hover north {c}", ("s2r_hover_north/Ambig_tracks_hover_north.rep",),
                    "s2r_hover_north/Ambig_tracks_hover_north.rep", "SUBJECT", "SENSOR", c)
          for c in ("HM", "TA")),
        SampleSet("AssetData Ambig TA", ("asset_ambig/Ambig_cuts_TA.rep",
                                         "asset_ambig/Ambig_tracks2.rep"),
                  "asset_ambig/Ambig_tracks2.rep", "SUBJECT"),
        SampleSet("AssetData Ambig HM", ("asset_ambig/Ambig_cuts_HM.rep",
                                         "asset_ambig/Ambig_tracks2.rep"),
                  "asset_ambig/Ambig_tracks2.rep", "SUBJECT"),
        # The own ship's hull and towed arrays fitted together (two sensors of one own ship).
        SampleSet("S2R hover north HM+TA", ("s2r_hover_north/Ambig_tracks_hover_north.rep",),
                  "s2r_hover_north/Ambig_tracks_hover_north.rep", "SUBJECT", "SENSOR"),
        SampleSet("AssetData Ambig HM+TA", ("asset_ambig/Ambig_cuts_TA.rep",
                                            "asset_ambig/Ambig_cuts_HM.rep",
                                            "asset_ambig/Ambig_tracks2.rep"),
                  "asset_ambig/Ambig_tracks2.rep", "SUBJECT"),
        # Of the Frigate's five sensors, only Frigate_Optic holds New_SSK on a straight leg.
        SampleSet("sen_frig Frigate_Optic", ("pepys/sen_frig_sensor.dsf", "pepys/sen_tracks.rep"),
                  "pepys/sen_tracks.rep", "New_SSK", "Frigate", "Frigate_Optic"),
        SampleSet("sen_ssk New_SSK_BB", ("sen/sen_ssk_sensor.dsf", "pepys/sen_tracks.rep"),
                  "pepys/sen_tracks.rep", "Frigate", "New_SSK", "New_SSK_BB"),
        *(SampleSet(f"bulk_data MER/{c}", ("pepys/bulk_data.rep",), "pepys/bulk_data.rep", c,
                    "MER", c)
          for c in ("GreenFV1_001", "GreenFV1_006", "GreenFV1_007", "GreenFV1_008",
                    "GreenFV1_010", "GreenFV1_011", "GreenFV1_012"))]


def unpacked(folder: Path) -> Path:
    """Copy the samples into ``folder``, ``.xz`` files unpacked; return the copy's root."""
    for path in DATA.rglob("*"):
        if path.is_file() and path.suffix in (".rep", ".dsf", ".xz"):
            target = folder / path.relative_to(DATA)
            target.parent.mkdir(parents=True, exist_ok=True)
            if path.suffix == ".xz":
                target.with_suffix("").write_bytes(lzma.decompress(path.read_bytes()))
            else:
                target.write_bytes(path.read_bytes())
    return folder


def straight_legs(track: dict[str, np.ndarray], min_fixes: int = 3
                  ) -> list[tuple[int, int, float, float]]:
    """Return the straight legs of a track: (first ns, last ns, course deg, speed kn).

    A leg is a run of consecutive fixes whose course and speed stay within 0.05 of the run's
    first (the simulator writes them to 0.01); runs of fewer than ``min_fixes`` are turns.
    """
    legs, start = [], 0
    course, speed, t = track["course"], track["speed"], track["time_ns"]
    for k in range(1, len(t) + 1):
        if k == len(t) or abs(course[k] - course[start]) > 0.05 or abs(
                speed[k] - speed[start]) > 0.05:
            if k - start >= min_fixes and speed[start] > 0:
                legs.append((int(t[start]), int(t[k - 1]), float(np.median(course[start:k])),
                             float(np.median(speed[start:k]))))
            start = k
    return legs


def readings(root: Path, rel: str) -> list[tuple[str, str | None]]:
    """Read every own ship's sensors of one file as tma does; return (what, refusal or None)."""
    files = [root / rel, *(root / c for c in COMPANIONS.get(rel, []))]
    out: list[tuple[str, str | None]] = []
    try:
        replay_tracks(files[0])
    except tk.MeasurementFileError as e:
        return [("parse", str(e))]
    text = files[0].read_text(encoding="latin-1")
    pairs = sorted({(parts[3].strip('"'), parts[4].strip())
                    for parts in (_sensor_fields(line) for line in text.splitlines())
                    if parts})
    for host, sensor in pairs:
        out += _read_contacts(files, text, host, sensor)
    return out or [("tracks only", None)]


def _read_contacts(files: list[Path], text: str, host: str, sensor: str
                   ) -> list[tuple[str, str | None]]:
    """Read one sensor's cuts; a sensor holding several contacts at once, one contact each.

    tmakit refuses two contacts' cuts at one time in one fit and asks for ``--contact``
    (the first word of the labels): each contact is then read as ``tma`` would be told to.
    """
    source = files if len(files) > 1 else files[0]
    try:
        meas = tk.read_measurements(source, ownship=host, contact=sensor)
        return [(f"{host}/{sensor}: {len(meas)} rows, "
                 f"{len(reader_notes(meas.metadata))} note(s)", None)]
    except (tk.MeasurementFileError, ValueError) as e:
        if "choose one with --contact" not in str(e):
            return [(f"{host}/{sensor}", str(e))]
    import re

    labels = sorted({m.group(1) for line in text.splitlines()
                     if (parts := _sensor_fields(line)) and parts[3].strip('"') == host
                     and parts[4] == sensor
                     and (m := re.search(rf"\b{re.escape(sensor)}\s+(\S+)", line))})
    out: list[tuple[str, str | None]] = []
    for label in labels:
        try:
            meas = tk.read_measurements(source, ownship=host, contact=label)
            out.append((f"{host}/{sensor}/{label}: {len(meas)} rows", None))
        except (tk.MeasurementFileError, ValueError) as e:
            out.append((f"{host}/{sensor}/{label}", str(e)))
    return out


def _sensor_fields(line: str) -> list[str] | None:
    """Return [kind, date, time, host, sensor] of a sensor line (None for other lines)."""
    import re

    tokens = re.findall(r'"[^"]*"|\S+', line)
    if not tokens or tokens[0].upper() not in (";SENSOR:", ";SENSOR2:", ";SENSOR3:"):
        return None
    at = 6 if tokens[5].upper() == "NULL" else 13
    at += {";SENSOR:": 2, ";SENSOR2:": 4, ";SENSOR3:": 5}[tokens[0].upper()]
    return [*tokens[:4], tokens[at].strip('"')] if len(tokens) > at else None


@dataclass(frozen=True)
class LegResult:
    """One leg's outcome."""

    sample: str
    start_ns: int
    end_ns: int
    course: float
    speed: float
    cuts: int
    verdict: str  # one of VERDICTS, or "too few cuts"
    text: str


def truth_bearing_error(root: Path, s: SampleSet) -> float:
    """Return the median |measured - true bearing| (deg) over every cut of a sample set.

    The true bearing is the one from the sensor's position at the cut to the subject's truth
    track (interpolated between its fixes): a few tenths of a degree when the truth track is
    the truth of the sensor file, tens of degrees when it is not.
    """
    files = [root / f for f in s.files]
    meas = tk.read_measurements(files if len(files) > 1 else files[0], ownship=s.ownship,
                                contact=s.contact, kinds=("bearing",))
    truth = replay_tracks(root / s.truth_file)[s.subject]
    t_ns = np.datetime64(meas.metadata["time_origin"].rstrip("Z"), "ns").astype(np.int64) + (
        np.round(meas.time * 1e9).astype(np.int64))
    lat, lon = (np.interp(t_ns, truth["time_ns"], truth[k]) for k in ("lat", "lon"))
    origin = [float(meas.metadata[f"origin_{k}"]) for k in ("lat", "lon", "alt")]
    east, north, _ = geodetic_to_enu(lat, lon, np.zeros(lat.shape), origin)
    true = np.arctan2(east - meas.sensor_state[:, 0], north - meas.sensor_state[:, 1])
    return float(np.degrees(np.median(np.abs(np.angle(np.exp(1j * (meas.value_si - true)))))))


def fit_leg(root: Path, s: SampleSet, leg: tuple[int, int, float, float]) -> LegResult:
    """Fit cv2d to the cuts of one leg and compare with the truth."""
    start, end, course, speed = leg
    files = [root / f for f in s.files]
    try:
        meas = tk.read_measurements(files if len(files) > 1 else files[0], ownship=s.ownship,
                                    contact=s.contact, kinds=KINDS,
                                    window=(iso_utc(start), iso_utc(end)))
    except ValueError as e:  # (an empty window is the window's fault, not the files')
        if "no cut between" not in str(e):
            raise
        return LegResult(s.name, start, end, course, speed, 0, "too few cuts",
                         "the contact was not held on this leg")
    cuts = len(np.unique(meas.time))
    if cuts < MIN_CUTS:
        return LegResult(s.name, start, end, course, speed, cuts, "too few cuts", "")
    result = tk.estimate(meas, "cv2d")
    if result.status == "unobservable":
        reason = "; ".join(d.sentence for d in result.bound.observability.directions)
        return LegResult(s.name, start, end, course, speed, cuts, "unobservable", reason)
    a = result.answer(meas)
    if a.course_deg is None or a.speed is None:
        return LegResult(s.name, start, end, course, speed, cuts, "undetermined",
                         "the data do not determine " + ", ".join(a.undetermined)
                         + f" (trust {result.trust(meas).level})")
    dc = abs((a.course_deg - course + 180.0) % 360.0 - 180.0)
    ds = abs(a.speed_knots - speed)
    sc, ss = a.course_std_deg, a.speed_std / KNOT
    if dc <= COURSE_TOL_DEG and ds <= SPEED_TOL_KN:
        verdict = "within"
    elif dc <= Z95 * sc and ds <= Z95 * ss:
        verdict = "uncertain"
    else:
        verdict = "off"
    trust = result.trust(meas)
    why = ", ".join(r.code for r in trust.reasons)
    text = (f"{a.course_deg:6.1f} +- {sc:.3g} deg, {a.speed_knots:5.2f} +- {ss:.3g} kn (error "
            f"{dc:.2f} deg, {ds:.2f} kn; {result.status}, chi2/dof "
            f"{result.chi2 / max(result.dof, 1):.3g}, trust {trust.level}"
            + (f": {why}" if why else "") + ")")
    return LegResult(s.name, start, end, course, speed, cuts, verdict, text)


def leg_results(root: Path) -> list[LegResult]:
    """Fit every straight leg of every sample set's subject (none when its truth is not)."""
    out = []
    for s in SETS:
        truth = replay_tracks(root / s.truth_file)[s.subject]
        legs = straight_legs(truth)
        error = truth_bearing_error(root, s)
        if error > TRUTH_MISMATCH_DEG:
            out += [LegResult(s.name, start, end, course, speed, 0, "not the truth",
                              f"the median bearing differs from the truth track's by "
                              f"{error:.1f} deg: this track is not the truth of these cuts")
                    for start, end, course, speed in legs]
            continue
        out += [fit_leg(root, s, leg) for leg in legs]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        root = unpacked(Path(tmp))
        names = sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())
        print(f"1. every file read ({len(names)} public sample files)")
        refused = 0
        for rel in names:
            outcome = readings(root, rel)
            bad = [f"{what}: {why}" for what, why in outcome if why is not None]
            refused += bool(bad)
            print(f"  {rel}: {'REFUSED ' + '; '.join(bad) if bad else 'read'} "
                  f"({'; '.join(what for what, why in outcome if why is None)})")
        print(f"  files read: {len(names) - refused} of {len(names)}, refused: {refused}")
        print(f"\n2. cv2d on each straight leg (kinds {','.join(KINDS)}; within "
              f"{COURSE_TOL_DEG:g} deg and {SPEED_TOL_KN:g} kn)")
        results = leg_results(root)
    for r in results:
        window = f"{iso_utc(r.start_ns)[11:19]}-{iso_utc(r.end_ns)[11:19]}"
        print(f"  {r.sample:24s} {window}  true {r.course:6.2f} deg {r.speed:5.2f} kn, "
              f"{r.cuts:3d} cuts: {r.verdict.upper()}: {r.text}")
    fitted = [r for r in results if r.verdict in VERDICTS]
    count = {v: sum(r.verdict == v for r in fitted) for v in VERDICTS}
    print(f"  legs with >= {MIN_CUTS} cuts and a true truth: {len(fitted)}; within: "
          f"{count['within']}, unobservable (said so): {count['unobservable']}, "
          f"undetermined (said so): {count['undetermined']}, uncertain (the "
          f"truth inside the printed 95 % intervals, no word said): {count['uncertain']}, off: "
          f"{count['off']}")
    print(f"  legs left out: {sum(r.verdict == 'too few cuts' for r in results)} with fewer "
          f"cuts, {sum(r.verdict == 'not the truth' for r in results)} whose truth track is "
          "not the truth of the cuts")

if __name__ == "__main__":
    main()
