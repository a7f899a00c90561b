"""Gaps outside the library answered ``unexplained`` with where (issue 27, item 2): effects written here from
the physics, not rigsim's laws, and library effects as controls.

The out-of-library effects are injected as an extra force on the plant simulator
(:class:`maglev_ocp.diagnosis.generate.ForcedPlant`, the runs recorded one after the other):

* **thermal drift of the magnets' remanence**: Nd-Fe-B loses about 0.12 % of its remanence per kelvin
  (temperature coefficient of Br, -0.12 %/K); a stage warming by 10 K/min during a session loses 1.2 %/min of
  its field and, the attraction going as B^2, 2.4 %/min of its pull. At the working gap the pull carries the
  mover's weight, so to first order the loss is a force ``2 kappa(tau) M g`` opening the gap, ``kappa`` growing
  linearly with the session time ``tau``;
* **a floor vibration**: the floor (and with it the stator) shaken at a fixed frequency is a base acceleration
  ``a_b sin(2 pi f t)``; in the stator's frame the mover feels the inertial force ``-M a_b sin(2 pi f t)`` on
  both axes (a floor moves in all directions), a narrow spectral line at ``f`` in both channels.

Controls: the plant without effects (``none``) and with a library effect (saturation), where no drift may be
reported. The tolerances were fixed before the first run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.diagnosis import DiagnoseSettings, diagnose
from maglev_ocp.diagnosis.generate import GeneratorSettings, generate_dataset
from maglev_ocp.diagnosis.outside import session_time, time_drift
from maglev_ocp.diagnosis.selftest import selftest_plant
from maglev_ocp.diagnosis.signatures import SIGNATURES, evidence
from maglev_ocp.diagnosis.stages.baseline import calibrate_baseline
from maglev_ocp.diagnosis.stages.localization import localize_gap, noise_stage
from maglev_ocp.diagnosis.stages.split import split_dataset
from maglev_ocp.params import NOMINAL

SMALL = GeneratorSettings(n_runs=6, run_duration=7.0)
BASE = NOMINAL.without_cogging()
#: Nd-Fe-B's temperature coefficient of the remanence [1/K].
ALPHA_BR = -1.2e-3


class RemanenceDrift:
    """The pull lost as the magnets warm at ``kelvin_per_min`` over the session (module docstring).

    The plant restarts its clock with every run; a run's start is seen as the time going back, and the
    session time is the runs' count times their length plus the time within the run.
    """

    def __init__(self, kelvin_per_min: float, run_s: float, mass: float = NOMINAL.Mv):
        self.rate, self.run_s, self.mass = kelvin_per_min / 60.0, run_s, mass
        self.run, self.last = -1, math.inf

    def kappa(self, tau: float) -> float:
        """Fractional loss of the remanence at session time ``tau`` [s]."""
        return -ALPHA_BR * self.rate * tau

    def __call__(self, t: float, x: np.ndarray) -> np.ndarray:
        if t < self.last:
            self.run += 1
        self.last = t
        tau = self.run * self.run_s + t
        return np.array([2.0 * self.kappa(tau) * self.mass * k.G, 0.0])


def floor_vibration(accel: float, freq_hz: float):
    """The inertial force of a base acceleration ``accel sin(2 pi f t)`` [m/s^2] on both axes."""

    def F(t: float, x: np.ndarray) -> np.ndarray:
        a = accel * math.sin(2 * math.pi * freq_hz * t)
        return np.array([-NOMINAL.Mv * a, -NOMINAL.Mh * a])

    return F


def _localized(dataset, seed: int):
    """The stages up to the noise model's evidence (split, baseline calibrated, localization, noise)."""
    st = DiagnoseSettings(seed=seed)
    split = split_dataset(dataset, st)
    base = calibrate_baseline(split, None, st, k.encoder_resolution)
    loc = localize_gap(split, base, st, np.random.default_rng(seed))
    noise, loc = noise_stage(split, base, loc, k.encoder_resolution, seed)
    return split, base, loc, noise


# ----------------------------------------------------------------------------- the test itself, on synthetic residuals
def _synthetic(rng: np.random.Generator, drift: float = 0.0, n_runs: int = 6, n: int = 1200, fs: float = 125.0):
    """Residuals of ``n_runs`` runs of ``n`` samples at ``fs``: AR(1) noise (rms 1, the filtered residual's
    correlation over a few samples) plus a state-dependent part (a law of g and d, what the state map takes),
    plus ``drift`` times the session time over the session (0 to ``drift`` from the first sample to the last)."""
    from maglev_ocp.diagnosis.residuals import PreparedRun, Residual

    runs = []
    total = n_runs * n / fs
    for i in range(n_runs):
        t = np.arange(n) / fs
        g = 0.018 + 0.004 * np.sin(2 * math.pi * (0.13 + 0.02 * i) * t + rng.uniform(0, 6))
        d = 0.04 * np.sin(2 * math.pi * (0.21 + 0.01 * i) * t + rng.uniform(0, 6))
        feat = {"t": t, "g": g, "d": d}
        for name in ("g_dot", "d_dot", "i_q", "i_d", "di_q", "di_d"):
            feat[name] = rng.standard_normal(n)
        e = np.zeros(n)
        w = rng.standard_normal(n)
        for j in range(1, n):
            e[j] = 0.8 * e[j - 1] + 0.6 * w[j]
        r = e + 2.0 * np.exp(-(g - 0.014) / 0.004) * np.cos(2 * math.pi * d / 0.05)
        r = r + drift * (i * n / fs + t) / total
        pr = PreparedRun(f"run_{i:02d}.csv", (), np.array([True, False]), np.zeros((n, 8)), None, np.zeros((n, 2)),
                         np.arange(n), feat)  # fmt: skip
        runs.append(Residual(pr, np.column_stack([r, np.full(n, np.nan)]), np.zeros((0, 2))))
    return runs[0::3] + runs[2::3], runs[1::3]  # training, held-out (interleaved in time)


def test_session_time_orders_runs_by_file_name():
    """The session time: the runs' places in the order of their file names times the longest run, plus the
    time within the run; pieces of a run cut at a stop keep their run's place."""
    train, test = _synthetic(np.random.default_rng(0))
    taus = session_time([*train, *test])
    by_name = {r.run.name: t for r, t in zip([*train, *test], taus, strict=True)}
    span = float(train[0].run.feat["t"][-1])
    for i in range(6):
        assert by_name[f"run_{i:02d}.csv"][0] == pytest.approx(i * span)


def test_time_drift_false_alarms_on_noise_and_state_structure():
    """No drift: a residual of correlated noise and a law of the state (what the library's effects are) is
    reported drifting in at most 2 of 60 draws (the test's z > 4 on a paired held-out comparison; a normal
    tail would give far less, the margin is for the map's own fitted noise), and never above the floor test."""
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(60):
        train, test = _synthetic(rng)
        td = time_drift(train, test, 0, floor=1.0)
        hits += bool(td is not None and td.significant)
    assert hits <= 2, hits


def test_time_drift_found_and_sized():
    """A drift of 5 noise rms over the session is found (z > 4) and its swing is recovered within 25 %;
    given a stiffness, the reading drift is the swing over it.

    The test's power on these residuals (two held-out runs of 1200 samples, AR(1) noise): drifts of 1.5, 3 and
    5 noise rms over the session found in 0, 85 and 100 % of 20 draws (median z 2.6, 5.0, 8.7; the swing
    recovered at each). This test was first written at 1.5 rms, before the power was measured, and failed
    (z = 1.6): a drift must be about 3 noise rms over the session to be named.
    """
    rng = np.random.default_rng(6)
    train, test = _synthetic(rng, drift=5.0)
    td = time_drift(train, test, 0, floor=1.0, mass=4.0, stiffness=-2000.0)
    assert td is not None and td.significant, td
    assert td.swing_m_s2 == pytest.approx(5.0, rel=0.25)
    assert td.force_n == pytest.approx(4.0 * td.swing_m_s2)
    assert td.reading_um == pytest.approx(td.swing_m_s2 / 2000.0 * 1e6)
    assert "drifting by" in td.describe() and "vertical" in td.describe()


# ----------------------------------------------------------------------------- end to end, on the plant simulator
#: A session as the self-check records it: six runs of 10 s, one after the other.
SESSION = GeneratorSettings(n_runs=6, run_duration=10.0)


def _dataset(seed: int, force=None, effects: dict | None = None):
    """A calibrated-baseline dataset of the self-check's plant (constants off nominal, the shared cogging law)
    with library ``effects`` switched on and ``force`` added."""
    cfg = selftest_plant("calibrated", effects or {})
    gen = generate_dataset(cfg, NOMINAL, seed=seed, settings=SESSION, extra_force=force, controller_params=NOMINAL)
    return gen.dataset


@pytest.mark.long  # a known limitation kept as a strict xfail: `make check-long` (it asserts nothing in CI's time)
@pytest.mark.xfail(
    strict=True,
    reason="measured 2026-11-29: unexplained, but through the non-white residual (5.3x the noise floor), not the "
    "drift: the plant generator's runs climb in gap band with their order (14 to 21 mm), so session time and gap "
    "are confounded and the drift test reaches z = 3.3 < 4 (swing 0.065 of the 0.196 m/s^2 lost, the rest "
    "taken by the gap map)",
)
def test_remanence_drift_is_unexplained_with_where():
    """The magnets warming by 8.3 K/min (the pull lost at 2 %/min, 2 % over the session): ``unexplained``, and
    the reasons locate a drift in session time in the vertical channel, sized as a force and a gap reading."""
    seed = 27101
    d = diagnose(_dataset(seed, RemanenceDrift(8.3, SESSION.run_duration)), settings=DiagnoseSettings(seed=seed))
    assert d.verdict.verdict == "unexplained", d.verdict.reasons
    where = [r for r in d.verdict.reasons if r.startswith("vertical: a drift in session time")]
    assert where and "N)" in where[0] and "as a reading of g drifting by" in where[0], d.verdict.reasons


@pytest.mark.long  # CI: an out-of-library effect `unexplained` (test_diagnosis.py), peaks (test_diagnosis_floor.py)
def test_floor_vibration_is_unexplained_at_its_frequency():
    """A floor shaken at 4.3 Hz (base acceleration 0.03 m/s^2 on both axes): ``unexplained``, with a line or
    band at 4.3 Hz (+-0.3 Hz) among the regions it leaves."""
    seed = 27102
    d = diagnose(_dataset(seed, floor_vibration(0.03, 4.3)), settings=DiagnoseSettings(seed=seed))
    assert d.verdict.verdict == "unexplained", d.verdict.reasons
    regs = [r for r in (d.remaining_regions or d.regions) if r.freq_band_hz]
    assert any(r.freq_band_hz[0] - 0.3 <= 4.3 <= r.freq_band_hz[1] + 0.3 for r in regs), regs


#: A library effect as a control: saturation of every magnetic term, 15 % lost at the upper stop.
SATURATION = {"saturation": {"enabled": True, "loss_8mm": 0.15, "ell_sat": 3e-3}}


@pytest.mark.slow
@pytest.mark.parametrize(("seed", "effects"), [(27103, {}), (27104, {}), (27105, SATURATION)])
def test_no_drift_without_an_effect_outside_the_library(seed, effects):
    """Controls: the plant without any effect, or with saturation (a law of the state), shows no drift in
    session time (the stages up to the noise model's evidence)."""
    _, _, loc, _ = _localized(_dataset(seed, effects=effects), seed)
    assert len(loc.drifts) == 2 and not loc.outside, [x.describe() for x in loc.drifts]


# ----------------------------------------------------------------------------- saturation follows the currents
def _state_runs(force, seed: int, n_runs: int = 3, n: int = 1500, floor: float = 0.02):
    """Held-out-like runs: smooth motion in g and d, currents that vary at a fixed state (the controller's
    dither and accelerations), and the residual ``force(feat, channel) + noise``."""
    import scipy.sparse as spa

    from maglev_ocp.diagnosis.residuals import PreparedRun, Residual

    rng = np.random.default_rng(seed)
    out = []
    for i in range(n_runs):
        t = np.arange(n) * 8e-3
        f1, f2, f3, f4 = rng.uniform(0.15, 0.5, 4)
        ph = rng.uniform(0, 2 * math.pi, 4)
        feat = {"t": t, "d": 0.04 * np.sin(2 * math.pi * f1 * t + ph[0]),
                "g": 0.016 + 0.004 * np.sin(2 * math.pi * f2 * t + ph[1]),
                "i_q": 1.5 * np.sin(2 * math.pi * f3 * t + ph[2]),
                "i_d": 1.0 + 1.0 * np.sin(2 * math.pi * f4 * t + ph[3])}  # fmt: skip
        for v in ("g", "d", "i_q", "i_d"):
            feat[f"{v}_dot" if v in ("g", "d") else f"d{v}"] = np.gradient(feat[v], t)
        r = np.column_stack([force(feat, 0), force(feat, 1)]) + floor * rng.standard_normal((n, 2))
        run = PreparedRun(f"run_{i:02d}.csv", (), np.array([True, True]), np.zeros((n, 8)), spa.csr_matrix((n, n)),
                          r, np.arange(n), feat)  # fmt: skip
        out.append(Residual(run, r, np.zeros_like(r)))
    return out


def _iron_loss(feat, c):
    """Saturation written for the test: the iron loses ``L(g) = 0.12 / (1 + ((g - 8 mm) / 4 mm)^2)`` of its
    flux (a Lorentzian knee, no library profile); the pull ``B^2`` loses ``2 L`` of 9.8 m/s^2, the PM-current
    pull (0.8 m/s^2 per A of i_d) and the thrust (1.2 m/s^2 per A of i_q) lose ``L``."""
    loss = 0.12 / (1.0 + ((feat["g"] - 8e-3) / 4e-3) ** 2)
    if c == 0:
        return -loss * (2 * 9.8 * 0.5 - 0.8 * feat["i_d"])
    return -loss * 1.2 * feat["i_q"]


def _soft_steel(feat, c):
    """A soft-steel part 30 mm beyond the gap's zero at d = 10 mm, pulling the mover as ``1 / r^7`` (a dipole
    field's ``B^2`` gradient): a law of the state alone, 0.3 m/s^2 at the closest approach."""
    ex, ez = feat["d"] - 0.01, feat["g"] + 0.03
    r = np.sqrt(ex**2 + ez**2)
    mag = 0.3 * (0.042 / r) ** 7
    return mag * (ez / r if c == 0 else -ex / r)


@pytest.mark.parametrize("seed", [8, 9])
def test_saturation_signature_needs_the_currents_at_a_fixed_state(seed):
    """A loss of the magnetic terms shows saturation's signature, its core too (it follows the currents at a
    fixed gap and position); a soft-steel pull, a law of the state alone, does not show the core, so
    saturation's signature does not show.

    Written first also asserting that the steel's pull shows saturation's gap terms (what made the core test
    necessary): true for seed 8 (share 0.12 against a null quantile of 0.065), not for seed 9 (0.063 against
    0.066), so that assertion was dropped; the core's is unchanged.
    """
    floors = {"vertical": 0.02, "horizontal": 0.02}
    sat = evidence("saturation", _state_runs(_iron_loss, seed), floors, seed=seed)
    assert sat.shows, sat.per_channel
    assert all(sat.per_channel[ch]["core_shows"] for ch in ("vertical", "horizontal")), sat.per_channel
    steel = evidence("saturation", _state_runs(_soft_steel, seed + 10), floors, seed=seed)
    assert not steel.shows, steel.per_channel


def test_line_less_effects_are_laws_of_the_gap_and_the_currents():
    """The resonance guard judges saturation, the commutation offset and a parameter error (no period in d,
    only gap, position and currents); not cogging or the end effect (their periods make lines of their own at
    a steady speed), nor friction, eddy drag or the lag (velocities, current rates: the lag has its own guard)."""
    from maglev_ocp.diagnosis.stages.guards import lineless

    assert [e for e in SIGNATURES if lineless(e)] == ["saturation", "commutation_offset", "parameter_error"]
