"""Loop transfer functions of a linearized controller and plant, and their margins (python-control).

The loop is broken one channel at a time with the other channel closed ("loop-at-a-time" margins),
at the plant input (a current channel) or at the plant output (a position reading). The broken loop
``L`` follows the negative-feedback convention of python-control (the closed loop is ``1 / (1 + L)``).

Per loop:

* gain margins: the closed loop stays stable for a gain ``k`` in ``(gm_lower, gm_upper)`` in the
  loop; ``gm_lower > 0`` when the plant is open-loop unstable (the gap axis): lowering the gain
  destabilizes too (``control.stability_margins``, all phase crossovers);
* phase margin and the gain crossover frequency;
* delay margin ``min_i PM_i / w_gc,i`` over the gain crossovers (the delay ``tau`` turns ``L(e^{jwTs})``
  by ``-w tau``; for whole samples this is exact in discrete time, ``z^-n``);
* disk margin ``alpha`` with skew 0 (balanced), ``alpha = 1 / ||S - I/2||_inf = 2 / ||S - T||_inf``
  and the disk-based gain and phase margins (Seiler, Packard, Gahinet, "An introduction to disk
  margins", IEEE Control Systems Magazine 40(5), 2020; the formulas of ``control.disk_margins``,
  evaluated on the same frequency response, which the tests check against python-control);
* peaks of ``|S|`` and ``|T|`` and the bandwidth where ``|T|`` first falls 3 dB below its value at
  low frequency.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass

import control
import numpy as np

from .controller_map import LinearController
from .plant_model import LinearPlant

#: Channel names: plant inputs (currents) and outputs (readings), and the axis each one drives.
INPUTS: tuple[str, ...] = ("i_q", "i_d")
OUTPUTS: tuple[str, ...] = ("g", "d")
#: Loop of each axis: the gap is driven by ``i_d`` (input 1), the position by ``i_q`` (input 0).
AXIS_INPUT: dict[str, int] = {"g": 1, "d": 0}
AXIS_OUTPUT: dict[str, int] = {"g": 0, "d": 1}


def closed_loop_matrix(plant: LinearPlant, ctrl: LinearController) -> np.ndarray:
    """State matrix of the linear closed loop (plant state, then controller memory)."""
    Ap, Bp, Cp = plant.A, plant.B, plant.C
    A = np.block([[Ap + Bp @ ctrl.D @ Cp, Bp @ ctrl.C], [ctrl.B @ Cp, ctrl.A]])
    return A


def broken_loop(plant: LinearPlant, ctrl: LinearController, where: str, channel: int) -> control.StateSpace:
    """Loop transfer function with the loop broken at one channel, the other channel closed.

    Parameters
    ----------
    plant, ctrl : LinearPlant, LinearController
        The linearized blocks (``u = C m + D y`` is the controller's command).
    where : {"input", "output"}
        Break at the plant input (current ``channel``) or at the reading ``channel``.
    channel : int
        0 or 1.

    Returns
    -------
    control.StateSpace
        ``L`` (discrete, ``dt = Ts``): minus the transfer from the injected signal back to the broken point.
    """
    Ap, Bp, Cp = plant.A, plant.B, plant.C
    Ak, Bk, Ck, Dk = ctrl.A, ctrl.B, ctrl.C, ctrl.D
    e = np.zeros((2, 1))
    e[channel] = 1.0
    Ebar = np.eye(2) - e @ e.T
    nm = Ak.shape[0]
    if where == "input":
        # u = Ebar u' + e v, u' = Ck m + Dk Cp x; output: e^T u'
        A = np.block([[Ap + Bp @ Ebar @ Dk @ Cp, Bp @ Ebar @ Ck], [Bk @ Cp, Ak]])
        B = np.vstack([Bp @ e, np.zeros((nm, 1))])
        C = np.hstack([e.T @ Dk @ Cp, e.T @ Ck])
    elif where == "output":
        # the controller reads y_c = Ebar Cp x + e w; output: e^T Cp x
        Cy = Ebar @ Cp
        A = np.block([[Ap + Bp @ Dk @ Cy, Bp @ Ck], [Bk @ Cy, Ak]])
        B = np.vstack([Bp @ Dk @ e, Bk @ e])
        C = np.hstack([e.T @ Cp, np.zeros((1, nm))])
    else:
        raise ValueError(f"where must be 'input' or 'output', got {where!r}")
    return control.ss(A, B, -C, np.zeros((1, 1)), dt=plant.Ts)


def frequency_grid(Ts: float, n: int = 4000, w_min: float = 0.5) -> np.ndarray:
    """Log-spaced frequencies [rad/s] from ``w_min`` to just below the Nyquist frequency ``pi / Ts``."""
    return np.logspace(math.log10(w_min), math.log10(0.999 * math.pi / Ts), n)


@dataclass
class LoopMargins:
    """Margins of one broken loop (see the module docstring).

    Attributes
    ----------
    gm_upper, gm_lower : float
        Gain margin interval [-]: stable for loop gains in ``(gm_lower, gm_upper)`` (``inf`` / 0 if none).
    pm_deg : float
        Smallest phase margin over the gain crossovers [deg].
    w_gc : float
        Gain crossover of that phase margin [rad/s].
    delay_margin_s : float
        Smallest ``PM / w_gc`` over the gain crossovers [s].
    disk_alpha, disk_gm_db, disk_pm_deg : float
        Balanced disk margin and its gain [dB] and phase [deg] margins.
    s_peak_db, t_peak_db : float
        Peaks of ``|S|`` and ``|T|`` [dB].
    bandwidth_rad_s : float
        First frequency where ``|T|`` is 3 dB below its low-frequency value [rad/s].
    closed_loop_stable : bool
        All closed-loop eigenvalues inside the unit circle.
    """

    gm_upper: float
    gm_lower: float
    pm_deg: float
    w_gc: float
    delay_margin_s: float
    disk_alpha: float
    disk_gm_db: float
    disk_pm_deg: float
    s_peak_db: float
    t_peak_db: float
    bandwidth_rad_s: float
    closed_loop_stable: bool

    def as_dict(self) -> dict[str, float | bool]:
        """Plain dict (JSON)."""
        return asdict(self)


def _db(x: float) -> float:
    return 20 * math.log10(x) if x > 0 else -math.inf


def loop_response(L: control.StateSpace, omega: np.ndarray) -> np.ndarray:
    """Frequency response ``L(e^{j w Ts})`` of a SISO discrete loop, by the return-difference identity.

    ``1 + L(z) = det(zI - A + B C) / det(zI - A) = prod (z - mu_i) / prod (z - lambda_i)`` (``D = 0``):
    closed-loop over open-loop poles, two eigenvalue problems instead of one linear solve per
    frequency (a loop with an NMPC's warm start has a few hundred states). Checked against
    python-control's direct evaluation at a few frequencies; that evaluation is used if they differ.
    """
    Ts = float(L.dt)
    A, B, C = np.asarray(L.A), np.asarray(L.B), np.asarray(L.C)
    if float(np.abs(L.D).max(initial=0)) != 0:
        raise ValueError("loop_response expects a strictly proper loop (D = 0)")
    z = np.exp(1j * np.asarray(omega, dtype=float) * Ts)
    lam = np.linalg.eigvals(A)
    mu = np.linalg.eigvals(A - B @ C)
    ratio = np.ones(z.size, dtype=complex)
    for a, b in zip(np.sort_complex(mu), np.sort_complex(lam), strict=True):
        ratio *= (z - a) / (z - b)
    resp = ratio - 1.0
    idx = np.unique(np.linspace(0, z.size - 1, 7).astype(int))
    direct = np.ravel(L(z[idx]))
    if not np.allclose(resp[idx], direct, rtol=1e-6, atol=1e-9):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)
            resp = np.ravel(L(z))
    return resp


def disk_margin_from_response(S: np.ndarray) -> tuple[float, float, float]:
    """Balanced disk margin ``alpha = 1 / max |S - 1/2|`` and its gain [dB] and phase [deg] margins.

    Seiler, Packard, Gahinet (2020), skew ``sigma = 0``: the loop tolerates gains in
    ``[(1 - alpha/2) / (1 + alpha/2), (1 + alpha/2) / (1 - alpha/2)]`` and phases up to
    ``2 atan(alpha / 2)`` at once; the same formulas as ``control.disk_margins`` for a SISO loop.
    """
    alpha = float(1.0 / np.max(np.abs(S - 0.5)))
    if alpha >= 2:
        return alpha, math.inf, 90.0
    gmax = (1 + alpha / 2) / (1 - alpha / 2)
    return alpha, 20 * math.log10(gmax), math.degrees(2 * math.atan(alpha / 2))


def loop_margins(
    L: control.StateSpace, omega: np.ndarray | None = None, response: np.ndarray | None = None
) -> LoopMargins:
    """Margins of a SISO discrete loop ``L`` (negative feedback), evaluated on ``omega``.

    ``response`` is ``L`` on ``omega`` if the caller has it already (:func:`loop_response`).

    Crossovers are found by ``control.stability_margins`` on the frequency response data of ``L``
    (a smoothed :class:`control.FrequencyResponseData`, which stays accurate for high-order
    discrete loops where the polynomial method would lose digits).
    """
    Ts = float(L.dt)
    w = frequency_grid(Ts) if omega is None else np.asarray(omega, dtype=float)
    Lw = loop_response(L, w) if response is None else np.asarray(response)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        frd = control.frd(Lw, w, dt=Ts)
        gm, pm, _sm, _wpc, wgc, _wms = control.stability_margins(frd, returnall=True)
    gm, pm, wgc = (np.atleast_1d(np.asarray(v, dtype=float)) for v in (gm, pm, wgc))
    gm = gm[np.isfinite(gm) & (gm > 0)]
    up, lo = gm[gm > 1], gm[gm < 1]
    ok = np.isfinite(pm) & np.isfinite(wgc) & (wgc > 0)
    pm, wgc = pm[ok], wgc[ok]
    if pm.size:
        i = int(np.argmin(pm))
        pm_min, w_pm = float(pm[i]), float(wgc[i])
        # a delay first reaches -1 at the crossover with the smallest (PM mod 360) / w
        dm = float(np.min(np.deg2rad(np.mod(pm, 360.0)) / wgc))
    else:
        pm_min, w_pm, dm = math.inf, math.nan, math.inf
    S = 1.0 / (1.0 + Lw)
    T = Lw * S
    alpha, dgm, dpm = disk_margin_from_response(S)
    t_mag = np.abs(T)
    below = np.nonzero(t_mag < t_mag[0] / math.sqrt(2))[0]
    bw = float(w[below[0]]) if below.size else math.inf
    A_cl = L.A - L.B @ L.C
    stable = bool(np.max(np.abs(np.linalg.eigvals(A_cl))) < 1.0)
    return LoopMargins(
        gm_upper=float(up.min()) if up.size else math.inf,
        gm_lower=float(lo.max()) if lo.size else 0.0,
        pm_deg=pm_min,
        w_gc=w_pm,
        delay_margin_s=dm,
        disk_alpha=alpha,
        disk_gm_db=dgm,
        disk_pm_deg=dpm,
        s_peak_db=_db(float(np.max(np.abs(S)))),
        t_peak_db=_db(float(np.max(t_mag))),
        bandwidth_rad_s=bw,
        closed_loop_stable=stable,
    )


__all__ = [
    "AXIS_INPUT",
    "AXIS_OUTPUT",
    "INPUTS",
    "OUTPUTS",
    "LoopMargins",
    "broken_loop",
    "closed_loop_matrix",
    "disk_margin_from_response",
    "frequency_grid",
    "loop_margins",
    "loop_response",
]
