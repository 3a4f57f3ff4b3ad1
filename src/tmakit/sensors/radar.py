"""The moving radar of Hurtado & Nehorai (2008): its array signal model and what it measures.

:class:`RadarModel` gives the Fisher information of the signal model (section 2.2, eqs. 4-6; the
amplitude eliminated, Stoica & Nehorai (1989)), the covariance of tmakit's bearing, elevation,
range and range rate, and the state information ``Xi`` (eq. 13); docs/radar_model.md has the
derivation and the values chosen where the paper is silent.

References
----------
Hurtado, M. and Nehorai, A. (2008), "Adaptive path design of a moving radar", eqs. 4-6, 13,
section 5.  Kershaw, D. J. and Evans, R. J. (1994), "Optimal waveform selection for tracking
systems".  Stoica, P. and Nehorai, A. (1989), "MUSIC, maximum likelihood, and Cramér-Rao bound".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..core.arrays import Array
from ..measurements import KINDS

__all__ = ["HURTADO_NEHORAI_2008_RADAR", "RADAR_KINDS", "RadarModel"]


def relative_states(target_states: ArrayLike, sensor_states: ArrayLike) -> tuple[Array, int]:
    """Return target minus sensor states (..., 6) (2-D targets at ``z = 0``) and the targets dim."""
    x = np.asarray(target_states, dtype=float)
    s = np.asarray(sensor_states, dtype=float)
    if x.ndim == 0 or x.shape[-1] not in (4, 6):
        raise ValueError("target states must have 4 (2-D: x, y, vx, vy) or 6 (3-D) "
                         f"components; got shape {x.shape}")
    if s.ndim == 0 or s.shape[-1] != 6:
        raise ValueError(f"sensor states must have 6 components (x, y, z, vx, vy, vz); got "
                         f"shape {s.shape}")
    dim = x.shape[-1] // 2
    target = np.zeros((*x.shape[:-1], 6))
    target[..., :dim] = x[..., :dim]
    target[..., 3:3 + dim] = x[..., dim:]
    return target - s, dim


def kind_rows(rel: Array, kinds: Sequence[str], jacobian: bool = False) -> Array:
    """Return the kinds' predictions (..., m) of relative states, or their Jacobians (..., m, 6)."""
    models = [KINDS[k]() for k in kinds]
    if jacobian:
        return np.stack([m.jacobian(rel).rel for m in models], axis=-2)
    return np.stack([m.predict(rel) for m in models], axis=-1)


#: The measured quantities in tmakit's kinds, the order of the full information matrix.
RADAR_KINDS = ("bearing", "elevation", "range", "range_rate")

#: Full width at half maximum of a Gaussian over its standard deviation, ``2 sqrt(2 ln 2)``.
FWHM_PER_SIGMA = 2.0 * math.sqrt(2.0 * math.log(2.0))

#: The smallest time-bandwidth product (half-power widths) of a Gaussian pulse, ``2 ln 2 / pi``.
MIN_TIME_BANDWIDTH = 2.0 * math.log(2.0) / math.pi

#: The pulse is sampled over +- this many RMS durations of ``|s|^2``.
WINDOW_SIGMAS = 8.0


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ValueError(f"RadarModel: {name} must be a finite positive number; got {value!r}")


def _choice(name: str, value: str, allowed: Sequence[str]) -> None:
    if value not in allowed:
        raise ValueError(f"RadarModel: {name} must be one of {', '.join(map(repr, allowed))}; "
                         f"got {value!r}")


@dataclass(frozen=True)
class RadarModel:
    """A mono-static pulse radar with a uniform circular array (Hurtado & Nehorai (2008)).

    The defaults are :data:`HURTADO_NEHORAI_2008_RADAR`: the paper's section 5 and, where the paper
    is silent, the values chosen in docs/radar_model.md.

    Parameters
    ----------
    carrier_frequency : float
        Carrier, Hz (paper: 10 GHz).
    bandwidth : float
        Full width at half maximum of the pulse's power spectrum, Hz (paper: 1 MHz).
    pulse_length : float
        Full width at half maximum of ``|s(t)|^2``, s (chosen: 10 us); at least
        ``2 ln 2 / (pi B)``, the chirp supplying the rest of the bandwidth.
    chirp : {"up", "down"}
        Sign of the chirp rate (the sign of the range / range-rate correlation).
    pri : float
        Pulse repetition interval, s (paper: 0.5 s): one measurement per PRI.
    elements : int
        Array elements M, at least 3 (paper: 6).
    spacing : float
        Distance between neighbouring elements, wavelengths (paper: 0.5); a horizontal uniform
        circular array, element 0 on the East axis.
    snr_db : float
        SNR at the receiver, dB (paper: 10 dB, independent of range).
    snr_per : {"pulse", "sample"}
        "pulse": per element after integration over the pulse (``E / N0``); "sample": per
        element and sample at the envelope's peak.
    sampling_rate : float
        Complex baseband sampling rate, Hz, at least ``2 B`` (chosen: 4 MHz).
    range_accuracy : {"derived", "resolution"}
        "derived": the CRB of the signal model; "resolution": range sigma ``c / (2 B)``,
        uncorrelated.
    speed_of_light : float
        Propagation speed c, m/s.

    Raises
    ------
    ValueError
        On a non-positive or non-finite number, fewer than 3 elements, an unknown option, a pulse
        shorter than the Gaussian limit, a sampling rate below ``2 B`` or a bandwidth above a tenth
        of the carrier (the model is narrow band).
    """

    carrier_frequency: float = 10e9
    bandwidth: float = 1e6
    pulse_length: float = 10e-6
    chirp: str = "up"
    pri: float = 0.5
    elements: int = 6
    spacing: float = 0.5
    snr_db: float = 10.0
    snr_per: str = "pulse"
    sampling_rate: float = 4e6
    range_accuracy: str = "derived"
    speed_of_light: float = 299_792_458.0

    def __post_init__(self) -> None:
        """Check the parameters (see Raises)."""
        for name in ("carrier_frequency", "bandwidth", "pulse_length", "pri", "spacing",
                     "sampling_rate", "speed_of_light"):
            _positive(name, getattr(self, name))
        if isinstance(self.elements, bool) or not isinstance(self.elements, (int, np.integer)) \
                or self.elements < 3:
            raise ValueError("RadarModel: elements must be an integer >= 3 (a uniform circular "
                             f"array needs three); got {self.elements!r}")
        if not (isinstance(self.snr_db, (int, float)) and math.isfinite(self.snr_db)):
            raise ValueError(f"RadarModel: snr_db must be a finite number; got {self.snr_db!r}")
        _choice("chirp", self.chirp, ("up", "down"))
        _choice("snr_per", self.snr_per, ("pulse", "sample"))
        _choice("range_accuracy", self.range_accuracy, ("derived", "resolution"))
        if self.pulse_length * self.bandwidth < MIN_TIME_BANDWIDTH * (1.0 - 1e-12):
            raise ValueError(
                f"RadarModel: pulse_length * bandwidth must be at least {MIN_TIME_BANDWIDTH:.4f} "
                f"(a Gaussian pulse); got {self.pulse_length * self.bandwidth:.4g}")
        if self.sampling_rate < 2.0 * self.bandwidth:
            raise ValueError(f"RadarModel: sampling_rate must be at least 2 * bandwidth "
                             f"({2.0 * self.bandwidth:g} Hz); got {self.sampling_rate:g}")
        if self.bandwidth > 0.1 * self.carrier_frequency:
            raise ValueError("RadarModel: bandwidth must be at most a tenth of the carrier "
                             "(the signal model is narrow band)")

    @property
    def wavelength(self) -> float:
        """Carrier wavelength ``lambda = c / f_c``, m."""
        return self.speed_of_light / self.carrier_frequency

    @property
    def array_radius(self) -> float:
        """UCA radius ``spacing lambda / (2 sin(pi / M))``, m."""
        return self.spacing * self.wavelength / (2.0 * math.sin(math.pi / self.elements))

    @property
    def element_positions(self) -> Array:
        """Element positions ``r_m`` (M, 3), m: horizontal circle, element 0 on the x axis."""
        a = 2.0 * np.pi * np.arange(self.elements) / self.elements
        r = self.array_radius
        return np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(a)], axis=1)

    @property
    def rms_duration(self) -> float:
        """RMS duration ``sigma_t`` of ``|s(t)|^2``, s."""
        return self.pulse_length / FWHM_PER_SIGMA

    @property
    def rms_bandwidth(self) -> float:
        """RMS bandwidth ``sigma_f`` of ``|S(f)|^2``, Hz."""
        return self.bandwidth / FWHM_PER_SIGMA

    @property
    def chirp_rate(self) -> float:
        """LFM chirp rate ``kappa``, Hz/s: ``sigma_f^2 = (4 pi sigma_t)^-2 + (kappa sigma_t)^2``."""
        st, sf = self.rms_duration, self.rms_bandwidth
        excess = max(sf * sf - 1.0 / (16.0 * math.pi**2 * st * st), 0.0)
        return (1.0 if self.chirp == "up" else -1.0) * math.sqrt(excess) / st

    @property
    def samples_per_pulse(self) -> int:
        """Samples N over ``+- 8 sigma_t`` at :attr:`sampling_rate` (odd, centred)."""
        return 2 * math.ceil(WINDOW_SIGMAS * self.rms_duration * self.sampling_rate) + 1

    @property
    def sample_offsets(self) -> Array:
        """Sample times relative to the echo's centre (N,), s."""
        n = self.samples_per_pulse
        return (np.arange(n, dtype=np.float64) - (n - 1) / 2.0) / self.sampling_rate

    @property
    def snr(self) -> float:
        """SNR per element after integration over the pulse, ``|b|^2 sum |s(t_n)|^2 / sigma^2``."""
        snr = 10.0 ** (self.snr_db / 10.0)
        if self.snr_per == "sample":
            snr *= float(np.sum(np.abs(self.pulse(self.sample_offsets)) ** 2))
        return snr

    @property
    def resolution_range_sigma(self) -> float:
        """Resolution-limited range sigma ``c / (2 B)``, m."""
        return self.speed_of_light / (2.0 * self.bandwidth)

    def pulse(self, t: ArrayLike) -> NDArray[np.complex128]:
        """Return the complex envelope ``s(t) = exp(-t^2 / (4 sigma_t^2) + j pi kappa t^2)``.

        Parameters
        ----------
        t : array_like
            Time from the pulse centre, s.

        Returns
        -------
        ndarray
            ``s(t)``, peak 1, the shape of ``t``.
        """
        t = np.asarray(t, dtype=float)
        st = self.rms_duration
        return np.exp(-t * t / (4.0 * st * st) + 1j * np.pi * self.chirp_rate * t * t)

    def signal(self, azimuth: float, elevation: float, delay: float, doppler: float,
               amplitude: complex | None = None, times: ArrayLike | None = None
               ) -> NDArray[np.complex128]:
        """Return the noise-free array output ``b p(phi, psi) s(t - tau) e^{j omega_D t}``.

        Parameters
        ----------
        azimuth, elevation : float
            The paper's ``phi`` (counter-clockwise from x = East) and ``psi``, rad.
        delay : float
            ``tau``, s.
        doppler : float
            ``omega_D``, rad/s.
        amplitude : complex, optional
            ``b``; default real with ``|b|^2 sum |s|^2`` = :attr:`snr` (noise variance 1).
        times : array_like, optional
            Sample times (N,), s; default ``delay +`` :attr:`sample_offsets`.

        Returns
        -------
        ndarray
            ``(N, M)`` complex samples.

        References
        ----------
        Hurtado & Nehorai (2008), §2.2, eq. 5.
        """
        t = self.sample_offsets + delay if times is None else np.asarray(times, dtype=float)
        if amplitude is None:
            energy = float(np.sum(np.abs(self.pulse(self.sample_offsets)) ** 2))
            amplitude = math.sqrt(self.snr / energy)
        u = np.array([math.cos(azimuth) * math.cos(elevation),
                      math.sin(azimuth) * math.cos(elevation), math.sin(elevation)])
        p = np.exp(2j * np.pi * (self.element_positions @ u) / self.wavelength)
        return np.asarray(amplitude * np.outer(self.pulse(t - delay)
                                               * np.exp(1j * doppler * t), p), np.complex128)

    def signal_information(self, elevation: ArrayLike = 0.0, dim: int = 3) -> Array:
        """Return the Fisher information of one pulse about the paper's parameters.

        Closed form with the echo's complex amplitude an unknown nuisance;
        it does not depend on the azimuth, the delay or the Doppler shift.

        Parameters
        ----------
        elevation : array_like
            The target's elevation ``psi``, rad (any shape).
        dim : {3, 2}
            3: about ``[phi, psi, tau, omega_D]``; 2: the 2-D reduction about ``[phi, tau,
            omega_D]`` (the elevation known, the target in the array's plane at ``psi``).

        Returns
        -------
        ndarray
            ``(..., 4, 4)`` or ``(..., 3, 3)``; units 1/rad^2, 1/s^2, s^2 and their products.

        Raises
        ------
        ValueError
            If ``dim`` is not 2 or 3.

        References
        ----------
        Hurtado & Nehorai (2008), eqs. 4-6; Kershaw & Evans (1994) (the pulse).
        """
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3; got {dim!r}")
        psi = np.asarray(elevation, dtype=float)
        s, m, st = self.snr, self.elements, self.rms_duration
        kr2 = (2.0 * np.pi * self.array_radius / self.wavelength) ** 2
        kappa = self.chirp_rate
        out = np.zeros((*psi.shape, 4, 4))
        out[..., 0, 0] = s * m * kr2 * np.cos(psi) ** 2
        out[..., 1, 1] = s * m * kr2 * np.sin(psi) ** 2
        out[..., 2, 2] = 2.0 * m * s * (1.0 / (4.0 * st * st) + 4.0 * np.pi**2 * kappa**2 * st**2)
        out[..., 2, 3] = out[..., 3, 2] = -2.0 * m * s * 2.0 * np.pi * kappa * st * st
        out[..., 3, 3] = 2.0 * m * s * st * st
        if dim == 2:
            keep = [0, 2, 3]
            out = out[..., keep, :][..., keep]
        return out

    @property
    def measurement_scale(self) -> Array:
        """``d [bearing, elevation, range, range_rate] / d [phi, psi, tau, omega_D]`` (4,)."""
        return np.array([-1.0, 1.0, self.speed_of_light / 2.0,
                         -self.wavelength / (4.0 * np.pi)])

    def measurement_information(self, elevation: ArrayLike = 0.0) -> Array:
        """Return the information about ``[bearing, elevation, range, range_rate]`` per pulse.

        The signal information mapped to tmakit's quantities; with ``range_accuracy=
        "resolution"`` the (range, range-rate) block is ``diag((2B / c)^2, 1 / var_rdot)``,
        ``var_rdot`` the derived marginal.

        Parameters
        ----------
        elevation : array_like
            The target's elevation, rad (any shape).

        Returns
        -------
        ndarray
            ``(..., 4, 4)``, SI: 1/rad^2, 1/m^2, s^2/m^2 and products.
        """
        inv = 1.0 / self.measurement_scale
        info = self.signal_information(elevation, dim=3) * np.outer(inv, inv)
        if self.range_accuracy == "resolution":
            time = info[..., 2:, 2:]
            var_rdot = time[..., 0, 0] / np.linalg.det(time)
            info[..., 2:, 2:] = 0.0
            info[..., 2, 2] = 1.0 / self.resolution_range_sigma**2
            info[..., 3, 3] = 1.0 / var_rdot
        return info

    @staticmethod
    def kinds(dim: int = 2) -> tuple[str, ...]:
        """Return the measured kinds: bearing, range, range_rate (3-D: and elevation).

        Parameters
        ----------
        dim : {2, 3}
            The dimension of the target state.

        Returns
        -------
        tuple of str

        Raises
        ------
        ValueError
            If ``dim`` is not 2 or 3.
        """
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3; got {dim!r}")
        return RADAR_KINDS if dim == 3 else ("bearing", "range", "range_rate")

    def measurement_covariance(self, kinds: Sequence[str] = ("bearing", "range", "range_rate"),
                               elevation: float = 0.0) -> Array:
        """Return the CRB covariance of the measured quantities of one pulse (SI).

        Without ``"elevation"`` among ``kinds`` the elevation is known (the 2-D reduction);
        quantities left out of ``kinds`` otherwise are still unknown (the marginal is given).

        Parameters
        ----------
        kinds : sequence of str
            Some of ``bearing`` (rad), ``elevation`` (rad), ``range`` (m), ``range_rate``
            (m/s), each once, in the order wanted.
        elevation : float
            The target's elevation, rad.

        Returns
        -------
        ndarray
            ``(m, m)`` covariance, SI units squared (range and range rate correlated).

        Raises
        ------
        ValueError
            On an unknown or repeated kind, or when the elevation is asked where the array
            gives no elevation information (a horizontal array at elevation 0).
        """
        names = [kinds] if isinstance(kinds, str) else list(kinds)
        bad = [k for k in names if k not in RADAR_KINDS]
        if bad or not names or len(set(names)) != len(names):
            raise ValueError(f"kinds must be distinct names among {', '.join(RADAR_KINDS)}; "
                             f"got {names!r}")
        info = self.measurement_information(float(elevation))
        active = [0, 1, 2, 3] if "elevation" in names else [0, 2, 3]
        if "elevation" in names and info[1, 1] <= 1e-12 * info[0, 0]:
            raise ValueError("a horizontal circular array has no elevation information at "
                             f"elevation {float(elevation)!r} rad; ask for an elevation "
                             "away from 0 or leave 'elevation' out of kinds")
        cov = np.linalg.inv(info[np.ix_(active, active)])
        pick = [active.index(RADAR_KINDS.index(k)) for k in names]
        return np.asarray(cov[np.ix_(pick, pick)], dtype=np.float64)

    def measurement_sigmas(self, kinds: Sequence[str] = ("bearing", "range", "range_rate"),
                           elevation: float = 0.0) -> Array:
        """Return the standard deviations ``(m,)`` of :meth:`measurement_covariance`, SI.

        Parameters
        ----------
        kinds, elevation : sequence of str, float
            As :meth:`measurement_covariance` (elevation in rad).

        Returns
        -------
        ndarray
        """
        return np.sqrt(np.diagonal(self.measurement_covariance(kinds, elevation)))

    def measure(self, target_states: ArrayLike, sensor_states: ArrayLike) -> Array:
        """Return the noise-free measurements of targets from sensors (broadcast).

        Parameters
        ----------
        target_states : array_like
            ``(..., 2 dim)``: ``[x, y, (z), vx, vy, (vz)]``, m and m/s (ENU).
        sensor_states : array_like
            ``(..., 6)``: ``[x, y, z, vx, vy, vz]``, m and m/s; leading axes broadcast with
            the targets'.

        Returns
        -------
        ndarray
            ``(..., m)``: :meth:`kinds` ``(dim)`` in order; rad, m, m/s.
        """
        rel, dim = relative_states(target_states, sensor_states)
        return kind_rows(rel, self.kinds(dim))

    def _information_at(self, rel: Array, dim: int) -> Array:
        info = self.measurement_information(kind_rows(rel, ("elevation",))[..., 0])
        return info if dim == 3 else info[..., [0, 2, 3], :][..., [0, 2, 3]]

    def state_information(self, target_states: ArrayLike, sensor_states: ArrayLike) -> Array:
        """Return ``Xi`` of Hurtado & Nehorai (2008), eq. 13: one pulse's information.

        ``Xi = H^T R^{-1} H`` with ``H`` the Jacobian of :meth:`measure` with respect to the
        target state and ``R^{-1}`` :meth:`measurement_information` at each target's
        elevation (2-D: the 2-D reduction), every sensor state against every target state.

        Parameters
        ----------
        target_states : array_like
            ``(N, 2 dim)`` or ``(2 dim,)``, m and m/s.
        sensor_states : array_like
            ``(C, 6)`` or ``(6,)``, m and m/s.

        Returns
        -------
        ndarray
            ``(C, N, 2 dim, 2 dim)`` (single-state axes dropped), SI: 1/m^2, s/m^2, s^2/m^2.

        References
        ----------
        Hurtado & Nehorai (2008), eqs. 4-6 and 13.
        """
        x, s = np.asarray(target_states, dtype=float), np.asarray(sensor_states, dtype=float)
        outer = s.ndim == 2 and x.ndim == 2  # every sensor state against every target state
        rel, dim = relative_states(x[None] if outer else x, s[:, None] if outer else s)
        d6 = kind_rows(rel, self.kinds(dim), jacobian=True)
        h = np.concatenate([d6[..., :dim], d6[..., 3:3 + dim]], axis=-1)
        info = self._information_at(rel, dim)
        return np.einsum("...ai,...ab,...bj->...ij", h, info, h)

    def simulate(self, target_states: ArrayLike, sensor_states: ArrayLike,
                 rng: np.random.Generator | int | None = None) -> Array:
        """Draw noisy measurements with the model's full covariance (broadcast).

        Parameters
        ----------
        target_states, sensor_states : array_like
            As for :meth:`measure` (leading axes broadcast element by element, e.g. a
            trajectory and the sensor states at the same times).
        rng : numpy.random.Generator or int, optional
            The random generator or a seed.

        Returns
        -------
        ndarray
            ``(..., m)``: :meth:`kinds` ``(dim)``; rad (bearings wrapped to (-pi, pi]), m, m/s.

        Raises
        ------
        ValueError
            In 3-D, at an elevation where the array gives no elevation information.
        """
        gen = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        z = self.measure(target_states, sensor_states)
        rel, dim = relative_states(target_states, sensor_states)
        info = self._information_at(rel, dim)
        if dim == 3 and np.any(info[..., 1, 1] <= 1e-12 * info[..., 0, 0]):
            raise ValueError("a horizontal circular array has no elevation information at "
                             "elevation 0: simulate 3-D targets away from the array's plane")
        chol = np.linalg.cholesky(np.linalg.inv(info))
        z = z + np.einsum("...ij,...j->...i", chol, gen.standard_normal(z.shape))
        z[..., 0] = np.angle(np.exp(1j * z[..., 0]))
        return z


#: The radar of Hurtado & Nehorai (2008), section 5, with the open values chosen here.
HURTADO_NEHORAI_2008_RADAR = RadarModel()
