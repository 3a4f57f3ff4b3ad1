"""The conventions every layer shares, written once: units, frames, geodesy, linear algebra.

* :mod:`.units` — physical constants and conversions (degrees, dB, dBm, wavelength, the
  free-space constant), the limits of a position and a time.
* :mod:`.frames` — the ENU frame and angle conventions (clockwise from North, wrapped).
* :mod:`.geodesy` — WGS-84 latitude, longitude and height to local East-North-Up and back.
* :mod:`.linalg` — numerically safe covariance algebra (Cholesky, Joseph update, PSD repair).
* :mod:`.blas` — products independent of the BLAS thread count, BLAS on one thread.
* :mod:`.arrays` — the one ``Array`` type of annotations; broadcasting and taking rows.
* :mod:`.keywords` — ``rng=`` (a seed or a Generator), renamed keywords, "not given".
* :mod:`.input_files` — what a file must be before it is read (regular, text if text).

Nothing here imports the rest of tmakit (the bottom layer, ``docs/architecture.md``).
"""
