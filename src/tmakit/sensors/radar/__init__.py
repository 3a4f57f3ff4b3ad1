"""The moving radar of Hurtado & Nehorai (2008): its array signal model and what it measures.

The paper (section 2.2, eqs. 4-6) writes the array output of one pulse as

    y(t) = p(phi, psi) s(t - tau) e^{j omega_D t} + e(t),   t = t_1, ..., t_N,

with the array response ``p_m = exp(j 2 pi u^T r_m / lambda)``, the direction
``u = [cos phi cos psi, sin phi cos psi, sin psi]``, the delay ``tau = 2 r / c``, a Doppler
shift ``omega_D`` (rad/s) and complex white Gaussian noise ``sigma^2 I``.  Section 5 gives
the radar: carrier 10 GHz, LFM pulses with a Gaussian envelope of 1 MHz bandwidth, PRI
0.5 s, a uniform circular array (UCA) of six elements 0.5 lambda apart, SNR 10 dB at the
receiver independent of range.  :class:`RadarModel` holds these and the values the paper
leaves open (its docstring), and derives:

* **the Fisher information** of the signal model about ``[phi, psi, tau, omega_D]``
  (:meth:`RadarModel.signal_information`).  The echo's complex amplitude ``b`` (the paper's
  eq. 4 has none; a real echo's phase is unknown, and the paper's baseband model drops the
  carrier phase ``exp(-j omega_c tau)``) is an unknown nuisance, eliminated by the Schur
  complement: ``J = (2 |b|^2 / sigma^2) Re(G^H P_g^perp G)`` with ``G = d g / d theta`` and
  ``P_g^perp`` the projection off the signal ``g`` (Stoica & Nehorai (1989), the concentrated
  Fisher information).  For a UCA centred on the origin (M >= 3) and the Gaussian LFM pulse
  ``s(t) = exp(-t^2 / (4 sigma_t^2) + j pi kappa t^2)`` it is block diagonal, in closed form::

      J_phi,phi   = S M (k R)^2 cos^2 psi          J_psi,psi = S M (k R)^2 sin^2 psi
      J_tau,tau   = 2 M S (1 / (4 sigma_t^2) + 4 pi^2 kappa^2 sigma_t^2) = 2 M S (2 pi sigma_f)^2
      J_tau,omega = -2 M S 2 pi kappa sigma_t^2    J_omega,omega = 2 M S sigma_t^2

  with ``S`` the SNR per element after integration over the pulse, ``k = 2 pi / lambda``,
  ``R`` the array radius, ``sigma_t`` and ``sigma_f`` the RMS duration and bandwidth of
  ``|s|^2`` and ``|S(f)|^2``; azimuth, elevation and (delay, Doppler) do not couple, and
  ``det J_time = (M S)^2`` whatever the chirp rate.  A horizontal planar array has no
  elevation information at zero elevation (``J_psi,psi = 0``).  tests/test_radar_model.py
  checks it against the brute-force FIM of the sampled signal (``2 Re(dh^H dh) / sigma^2``
  from finite differences, amplitude and phase eliminated numerically).
* **the covariance of tmakit's measurements** (:meth:`RadarModel.measurement_covariance`):
  ``bearing = pi/2 - phi`` (tmakit's azimuth, clockwise from North, ``atan2(east, north)``;
  the paper's ``phi = atan2(y, x)`` is counter-clockwise from ``x`` = East), ``elevation =
  psi``, ``range = c tau / 2`` and ``range_rate = -lambda omega_D / (4 pi)``.  The paper
  writes ``omega_D = (2 pi / (lambda r)) (x xdot + y ydot + z zdot) = 2 pi rdot / lambda``:
  the one-way factor with the sign of a receding target raising the frequency.  A mono-static
  radar's echo travels the path twice and a receding target lowers it: ``omega_D = -4 pi
  rdot / lambda`` (``f_D = -2 rdot / lambda``), used here; the paper's factor would double
  every range-rate sigma.  The LFM chirp couples delay and Doppler, so range and range rate
  are correlated (negatively for an up-chirp); the full matrix is kept.
* **the information about the state** (:meth:`RadarModel.state_information`): ``Xi`` of
  Hurtado & Nehorai (2008), eq. 13, ``H^T R^{-1} H`` chained through the Jacobian of the
  relation after eq. 4 (range, bearing, elevation and range rate of the relative state).

Range accuracy (``range_accuracy``)
-----------------------------------
``"derived"`` (the default) is the Cramér-Rao bound of the paper's own signal model above.
``"resolution"`` replaces the range sigma by the resolution-limited ``c / (2 B)`` (150 m for
1 MHz), uncorrelated with the rest; azimuth, elevation and range rate stay the derived ones
(the range rate is then the derived *marginal*, of little use on its own).  I believe the
derived model for reproducing the paper: it is the paper's eqs. 4-6 and its eq. 13 says
``Xi`` comes from that model; the marginal range sigma it gives (116 m with the default 10 us
pulse) is the same size as ``c / (2 B)``, but the chirp's range-Doppler coupling makes one
combination of range and range rate known to ~5 m, which a tracker exploits once it knows the
range rate from the track.  The CRB is reachable above the estimation threshold (here 10 dB
per element, 17.8 dB over the array) for a point target; an extended target, glint or range
migration would floor the range error near a fraction of a resolution cell, for which
``"resolution"`` is the conservative bound.  docs/radar_model.md has the numbers
(benchmarks/radar_model.py prints them).

The paper's eq. 4 and every quantity here are per pulse: one measurement of
``[bearing, (elevation,) range, range_rate]`` each PRI.  The radar's measurement group with
the full covariance, for filters, bounds and planners, is
:func:`tmakit.observation.radar_group` (the observation layer sits above this one).

References
----------
Hurtado, M. and Nehorai, A. (2008), "Adaptive path design of a moving radar", eqs. 4-6, 13,
section 5.  Kershaw, D. J. and Evans, R. J. (1994), "Optimal waveform selection for tracking
systems" (the Gaussian-envelope LFM pulse and its delay-Doppler CRB).  Stoica, P. and
Nehorai, A. (1989), "MUSIC, maximum likelihood, and Cramér-Rao bound" (the concentrated FIM
with an unknown complex amplitude).
"""

from .geometry import elevation_of, measurement_jacobian, measurements, relative_states
from .model import HURTADO_NEHORAI_2008_RADAR, RADAR_KINDS, RadarModel

__all__ = ["HURTADO_NEHORAI_2008_RADAR", "RADAR_KINDS", "RadarModel", "elevation_of",
           "measurement_jacobian", "measurements", "relative_states"]
