"""The radar of Hurtado & Nehorai (2008), section 5: a derivation report.

Prints every parameter of :data:`tmakit.sensors.HURTADO_NEHORAI_2008_RADAR` (the paper's and
the chosen ones), the derived waveform and array quantities, and the per-pulse sigmas of
azimuth (deg), range (m) and range rate (m/s) with the range / range-rate correlation, for the
derived CRB model and the resolution-limited one (``c / 2B``); then how the derived sigmas move
with the open choices (pulse length, SNR counting, the paper's one-way Doppler factor).

    PYTHONPATH=src python benchmarks/radar_model.py
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from tmakit.sensors import HURTADO_NEHORAI_2008_RADAR, RadarModel


def sigmas(radar: RadarModel, doppler_factor: float = 1.0) -> dict[str, float]:
    """Per-pulse sigmas and correlation of (bearing, range, range rate) of a radar."""
    cov = radar.measurement_covariance(("bearing", "range", "range_rate"))
    s = np.sqrt(np.diagonal(cov))
    rho = cov[1, 2] / (s[1] * s[2])
    return {"azimuth_deg": math.degrees(s[0]), "range_m": s[1],
            "range_rate_mps": s[2] * doppler_factor, "rho": rho,
            "range_given_rate_m": s[1] * math.sqrt(max(1.0 - rho * rho, 0.0))}


def row(label: str, v: dict[str, float]) -> str:
    """One line of the sigma table."""
    return (f"{label:<40} {v['azimuth_deg']:9.3f} {v['range_m']:10.2f} "
            f"{v['range_rate_mps']:12.2f} {v['rho']:9.5f} {v['range_given_rate_m']:12.2f}")


def main() -> None:
    """Print the report."""
    r = HURTADO_NEHORAI_2008_RADAR
    print("Radar of Hurtado & Nehorai (2008), section 5 "
          "(tmakit.sensors.HURTADO_NEHORAI_2008_RADAR)")
    print("\nParameters (paper = given in section 5; chosen = left open by the paper)")
    origin = {"carrier_frequency": "paper", "bandwidth": "paper (value); -3 dB: chosen",
              "pulse_length": "chosen", "chirp": "chosen", "pri": "paper",
              "elements": "paper", "spacing": "paper", "snr_db": "paper",
              "snr_per": "chosen", "sampling_rate": "chosen", "range_accuracy": "variant",
              "speed_of_light": "constant"}
    for f in dataclasses.fields(r):
        print(f"  {f.name:<18} {getattr(r, f.name)!s:<16} {origin[f.name]}")
    print("\nDerived")
    print(f"  wavelength          {r.wavelength * 1e3:.3f} mm")
    print(f"  array radius        {r.array_radius * 1e3:.3f} mm "
          f"(= {r.array_radius / r.wavelength:.3f} lambda; horizontal UCA)")
    print(f"  RMS duration        {r.rms_duration * 1e6:.3f} us (of |s(t)|^2)")
    print(f"  RMS bandwidth       {r.rms_bandwidth * 1e-3:.1f} kHz (of |S(f)|^2)")
    print(f"  chirp rate          {r.chirp_rate:.4e} Hz/s "
          f"(sweep over the -3 dB pulse: {r.chirp_rate * r.pulse_length * 1e-6:.3f} MHz)")
    print(f"  time-bandwidth      {r.pulse_length * r.bandwidth:.2f} (half-power widths)")
    print(f"  samples per pulse   {r.samples_per_pulse} at {r.sampling_rate * 1e-6:g} MHz "
          f"(+- 8 RMS durations)")
    print(f"  SNR per element     {10 * math.log10(r.snr):.2f} dB after integration "
          f"({10 * math.log10(r.snr * r.elements):.2f} dB over the array)")
    print(f"  c / 2B              {r.resolution_range_sigma:.2f} m")

    head = (f"\n{'variant':<40} {'az (deg)':>9} {'range (m)':>10} {'rdot (m/s)':>12} "
            f"{'rho r,rdot':>9} {'r|rdot (m)':>12}")
    print(head)
    print(row("derived (CRB, default)", sigmas(r)))
    print(row("resolution (c/2B, uncorrelated)",
              sigmas(dataclasses.replace(r, range_accuracy="resolution"))))

    print("\nSensitivity of the derived sigmas to the open choices")
    print(head[1:].replace("variant", "choice "))
    t0 = 2.0 * math.log(2.0) / (math.pi * r.bandwidth)
    print(row(f"pulse length {t0 * 1e6:.3f} us (no chirp)",
              sigmas(dataclasses.replace(r, pulse_length=t0))))
    for t in (1e-6, 3e-6, 10e-6, 30e-6, 100e-6):
        print(row(f"pulse length {t * 1e6:g} us", sigmas(dataclasses.replace(r, pulse_length=t))))
    print(row("SNR 10 dB per sample (peak)", sigmas(dataclasses.replace(r, snr_per="sample"))))
    print(row("down-chirp", sigmas(dataclasses.replace(r, chirp="down"))))
    print(row("paper's one-way Doppler 2 pi / lambda", sigmas(r, doppler_factor=2.0)))
    print("\nr|rdot: the range sigma when the range rate is known (the coupled direction).")
    print("Elevation (3-D): the horizontal UCA's elevation sigma at elevation 10 deg is "
          f"{math.degrees(r.measurement_sigmas(('elevation',), math.radians(10.0))[0]):.2f} deg "
          "(none at 0 deg).")


if __name__ == "__main__":
    main()
