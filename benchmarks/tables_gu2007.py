"""Tables 1-3 of Gu et al. (2007): the CRLB RMS values (C and f_s known) for power only,
Doppler only and both, at (SNR_p, sigma_f) = (40 dB, 1.9 Hz), (20 dB, 1.9 Hz), (40 dB, 19 Hz),
computed by tmakit on the gu2007 scenario next to the paper's printed numbers.

    python benchmarks/tables_gu2007.py
"""

from __future__ import annotations

from tmakit.reproduce.gu2007 import PAPER_TABLES, PARAMS, crlb_tables


def main() -> None:
    ours = crlb_tables()
    worst = 0.0
    print(f"{'setting':<16}{'kinds':<11}{'param':<7}{'paper':>11}{'tmakit':>12}{'rel. diff':>11}")
    for (snr, sigma_f), paper in PAPER_TABLES.items():
        for kinds, values in paper.items():
            for i, p in enumerate(PARAMS):
                v = float(ours[(snr, sigma_f)][kinds][i])
                rel = abs(v - values[i]) / values[i]
                worst = max(worst, rel)
                print(f"{snr:>4g} dB {sigma_f:>4g} Hz  {kinds:<11}{p:<7}{values[i]:>11.4f}"
                      f"{v:>12.4f}{rel:>11.1e}")
    print(f"36 entries; largest relative difference {worst:.2e} (goal: below 1e-3)")


if __name__ == "__main__":
    main()
