"""The fourth law set of the independent rig (maglev_ocp.rigsim.laws_v4, ``laws="v4"``, issue 27).

Each law is checked against a value, symmetry or limit its source states, with the truth computed here from
the source's formula or physics (numerical integration, the rig's own MODEL.md field, a transfer function
built apart from the law's state space), tolerances fixed beforehand; the v4 draw is seeded, covers every
family, stays finite and bounded over the rig's envelope; datasets generated from the law sets before it are
the same bytes as at commit 934155e (before this set; the earlier sets' draws: test_rigsim_draw_bytes.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from law_checks import check_law_over_envelope, envelope_grid
from rig_bytes import assert_same_datasets, dataset_hash
from scipy import integrate, signal

from maglev_ocp import constants as k
from maglev_ocp.rigsim import RigSettings, draw, generate
from maglev_ocp.rigsim.laws import Friction
from maglev_ocp.rigsim.laws_v4 import V4_LAWS, make_law
from maglev_ocp.rigsim.physics import NOMINAL, accelerations, shape
from maglev_ocp.rigsim.sim import Rig

G_LO, G_HI = k.g_stop
LAM = 2 * k.t1
KP = math.pi / k.tau


def _B(g):
    """MODEL.md's field of the array at the stator surface (the rig's physics module)."""
    return float(shape(np.array([g])).B[0])


# ----------------------------------------------------------------------------- cogging
@pytest.mark.parametrize("family", ["magnet_shift", "permeance_wave"])
def test_cogging_is_conservative_with_zero_mean(family):
    spec = {"family": family, "xi0": 3.0}
    if family == "magnet_shift":
        spec.update(beta0=0.03, e2=3e-4, sigma=0.3)
    law = make_law("cogging", spec)
    g = np.linspace(9e-3, 25e-3, 7)[:, None] + 0 * np.linspace(-0.05, 0.05, 11)[None, :]
    d = 0 * g + np.linspace(-0.05, 0.05, 11)[None, :]
    h = 1e-7
    dfd_dg = (law.force(g + h, 0, d, 0)[1] - law.force(g - h, 0, d, 0)[1]) / (2 * h)
    dfg_dd = (law.force(g, 0, d + h, 0)[0] - law.force(g, 0, d - h, 0)[0]) / (2 * h)
    scale = np.max(np.abs(dfd_dg))
    assert scale > 10.0
    assert np.max(np.abs(dfd_dg - dfg_dd)) < 1e-5 * scale
    dp = np.linspace(0, LAM, 400, endpoint=False)
    fd = law.force(0 * dp + 0.012, 0, dp, 0)[1]
    assert abs(np.mean(fd)) < 1e-9 * np.max(np.abs(fd))


def test_magnet_shift_array_factor():
    # Bianchi et al.: shifting magnet j by j lambda / pm cancels every harmonic below pm (here k = 1..3)
    law = make_law("cogging", {"family": "magnet_shift", "sigma": 1.0})
    d = np.linspace(-0.05, 0.05, 41)
    fg, fd = law.force(0 * d + 0.015, 0, d, 0)
    assert np.max(np.abs(fd)) < 1e-12 and np.max(np.abs(fg)) < 1e-12
    # a perfect unshifted array (tau = 1.5 lambda): odd harmonics cancel, harmonic 2 is whole:
    # Fd = xi0 (B(g)/B(g_ref))^2 c2 / sum|c| sin(4 pi d / lambda + phi2)
    law = make_law("cogging", {"family": "magnet_shift", "xi0": 2.0, "c1": 1.0, "c2": 0.5, "c3": 0.5, "phi2": 0.3})
    g = 0.017
    want = 2.0 * (_B(g) / _B(k.g_cog_ref)) ** 2 * 0.25 * np.sin(4 * math.pi * d / LAM + 0.3)
    assert law.force(0 * d + g, 0, d, 0)[1] == pytest.approx(want, abs=1e-12)
    # Gasparin et al.: one magnet 3 % stronger brings the fundamental back, M_1 = (1.03^2 - 1) / pm
    law = make_law("cogging", {"family": "magnet_shift", "xi0": 2.0, "c1": 1.0, "c2": 0.0, "c3": 0.0, "beta0": 0.03})
    x = np.linspace(0, LAM, 512, endpoint=False)
    fd = law.force(0 * x + k.g_cog_ref, 0, x, 0)[1]
    amp1 = 2 * abs(np.fft.rfft(fd)[1]) / x.size
    assert amp1 == pytest.approx(2.0 * (1.03**2 - 1) / k.pm, rel=1e-9)


def test_permeance_wave_follows_the_pull_energy():
    # W_pm(g) ~ the pull integrated over the gap; MODEL.md's pull ~ B(g)^2: the ripple at gap g over the one at
    # g_ref is int_g B^2 / int_gref B^2 times exp(-2 pi (g - g_ref) / lambda) (numerical quadrature here)
    law = make_law("cogging", {"family": "permeance_wave", "xi0": 4.0, "r2": 0.0, "d0": 0.0})

    def energy(g):
        return integrate.quad(lambda x: _B(x) ** 2, g, 1.0, limit=200)[0]

    dq = LAM / 4  # sin(2 pi d / lambda) = 1
    for g in (0.012, 0.02):
        want = 4.0 * energy(g) / energy(k.g_cog_ref) * math.exp(-2 * math.pi * (g - k.g_cog_ref) / LAM)
        assert law.force(np.array([g]), 0, np.array([dq]), 0)[1][0] == pytest.approx(want, rel=1e-6)
    # the normal ripple (at d = 0, cos = 1) is -dW/dg: larger than the tangential one (pull x permeance ripple)
    fg = law.force(np.array([0.015]), 0, np.array([0.0]), 0)[0][0]
    fd = law.force(np.array([0.015]), 0, np.array([dq]), 0)[1][0]
    assert 1.5 < fg / fd < 3.0


# ---------------------------------------------------------------------------- friction
def _drive(law, path, h=1e-4):
    """Move the g axis along the displacement increments ``path`` (each over ``h``); the force after each."""
    return np.array([law.held(np.array([dx / h]), np.array([0.0]), h)[0][0] for dx in path])


def test_bouc_wen_loading_and_reversal():
    p = {"family": "bouc_wen", "Fc_g": 0.3, "x_c": 2e-5, "rho": 2.5, "b_g": 0.0}
    law = make_law("friction", p)
    law.reset(1)
    f = _drive(law, [1e-6] * 30)  # from rest: F = -Fc (1 - exp(-p / x_c)), whatever the speed
    assert f[-1] == pytest.approx(-0.3 * (1 - math.exp(-30e-6 / 2e-5)), rel=1e-10)
    law2 = make_law("friction", p)
    law2.reset(1)
    assert _drive(law2, [3e-6] * 10, h=1e-3)[-1] == pytest.approx(f[-1], rel=1e-10)  # rate independent
    _drive(law, [1e-5] * 100)  # saturated at z = x_c
    # reversal: the force crosses zero after x_c ln(1 + rho) / rho of travel (the unloading branch, lambda_-)
    p_star = 2e-5 * math.log(1 + 2.5) / 2.5
    n = 200
    fr = _drive(law, [-p_star / n] * n)
    assert abs(fr[-1]) < 1e-9 * 0.3


def test_bouc_wen_with_equal_rates_is_dahl():
    # rho = 1 (gamma = 0): Dahl's law with sigma = Fc / x_c (the rig's first friction family, laws.py)
    bw = make_law("friction", {"family": "bouc_wen", "Fc_g": 0.2, "x_c": 1e-5, "rho": 1.0, "b_g": 0.0})
    dahl = Friction("dahl", Fc_g=0.2, sigma=0.2 / 1e-5, b_g=0.0)
    bw.reset(1), dahl.reset(1)
    path = [2e-6] * 20 + [-3e-6] * 25 + [1e-6] * 10
    assert _drive(bw, path) == pytest.approx(_drive(dahl, path), rel=1e-9, abs=1e-12)


def test_seven_parameter_model_memory_and_dwell():
    p = {"family": "seven_param", "Fc_g": 0.1, "Fv_g": 0.5, "Fs_g": 0.2, "a_ratio": 0.4, "gam": 0.2}
    p.update(tau_L=5e-3, vs=4e-3, v_reg=1e-4)
    law = make_law("friction", p)
    law.reset(1)
    h = 1e-4
    for _ in range(3000):  # 0.3 s at rest
        law.held(np.array([0.0]), np.array([0.0]), h)
    v = 0.02
    f1 = law.held(np.array([v]), np.array([0.0]), h)[0][0]
    fs = 0.2 * (0.4 + 0.6 * 0.3 / (0.3 + 0.2))  # Armstrong: Fs_a + (Fs_inf - Fs_a) t_d / (t_d + gamma)
    vl = v * (1 - math.exp(-h / 5e-3))
    want = -(0.1 + 0.5 * v + fs / (1 + (vl / 4e-3) ** 2)) * math.tanh(v / 1e-4)
    assert f1 == pytest.approx(want, rel=1e-9)
    for _ in range(199):  # 20 ms of sliding: the Stribeck part decays through the lagged velocity
        f = law.held(np.array([v]), np.array([0.0]), h)[0][0]
    vl = v * (1 - math.exp(-200 * h / 5e-3))
    assert f == pytest.approx(-(0.1 + 0.5 * v + fs / (1 + (vl / 4e-3) ** 2)), rel=1e-9)


# -------------------------------------------------------------------------- end effects
def test_winding_shorter_than_iron():
    # g -> 0: the overlaps are geometric, 1 - overhang / L, the winding's ends w earlier than the iron's
    law = make_law("end_effect", {"family": "winding_iron", "e_ip": 0.03, "e_in": 0.02, "w_p": 0.01, "w_n": 0.005})
    L = k.pm * k.tau
    d, g = np.array([0.05, -0.05, 0.0]), np.array([1e-9] * 3)
    f = [np.ones(3) for _ in range(4)]
    law.factors(g, d, f)
    iron = np.array([1 - 0.02 / L, 1 - 0.03 / L, 1.0])
    wind = np.array([1 - 0.03 / L, 1 - 0.035 / L, 1.0])
    assert f[2] == pytest.approx(iron, abs=1e-7)  # the magnets' pull (C2 term)
    assert f[2] * f[1] == pytest.approx(wind, abs=1e-7)  # the currents' force (C1, C3 terms)


def test_end_force_is_the_virtual_work_of_the_pull():
    # F_d = W(g) drho/dd with W the pull of MODEL.md integrated over the gap (quadrature; lam(g) varies a little)
    law = make_law("end_effect", {"family": "energy_overhang", "e_p": 0.02, "e_n": 0.03})
    g = 0.018

    def pull(x):
        return NOMINAL.Mv * NOMINAL.C2 * float(shape(np.array([x])).f2[0])

    W = integrate.quad(pull, g, 1.0, limit=200)[0]
    h = 1e-6
    for d in (0.045, -0.05):
        drho = (law.rho_g(np.array([d + h]), np.array([g]))[0] - law.rho_g(np.array([d - h]), np.array([g]))[0]) / (
            2 * h
        )
        fd = law.force(np.array([g]), 0, np.array([d]), 0)[1][0]
        assert fd == pytest.approx(W * drho, rel=0.03)
        assert np.sign(fd) == -np.sign(d)  # back over the stator
    assert law.rho_g(np.array([0.0]), np.array([g]))[0] == pytest.approx(1.0, abs=1e-15)


# --------------------------------------------------------------------------- saturation
def test_exp_sum_at_a_point_and_linear_limit():
    law = make_law("saturation", {"family": "exp_sum", "b1": 0.4, "b2": 1.2, "w1": 0.3})

    def r(u):
        return 0.3 * (1 - math.exp(-0.4 * u)) / (0.4 * u) + 0.7 * (1 - math.exp(-1.2 * u)) / (1.2 * u)

    x, x_hi = _B(0.013) / _B(G_LO), _B(G_HI) / _B(G_LO)
    assert law.loss(np.array([0.013]))[0] == pytest.approx(1 - r(x) / r(x_hi), rel=1e-10)
    loss = law.loss(np.linspace(G_LO, G_HI, 25))
    assert np.all(np.diff(loss) < 0) and loss[-1] == pytest.approx(0.0, abs=1e-15)
    tiny = make_law("saturation", {"family": "exp_sum", "b1": 1e-7, "b2": 1e-7})
    assert abs(tiny.loss(np.array([G_LO]))[0]) < 1e-6


def test_dq_flux_saturation_follows_the_net_flux():
    law = make_law("saturation", {"family": "dq_flux", "a": 1.0, "target": "both"})
    g = 0.014
    # kappa from seed eq. (2): the pull C2 f2 - C3 f3 i + C4 f4 i^2 ~ C2 f2 (1 - kappa i)^2, so
    # d sqrt(pull) / di at i = 0 over sqrt(pull) is -kappa (the rig's physics, finite differences)
    h = 1e-4

    def pull(i):
        return k.G - accelerations(g, 0.0, 0.0, i, NOMINAL, with_cogging=False)[0]

    kappa = -(math.sqrt(pull(h)) - math.sqrt(pull(-h))) / (2 * h) / math.sqrt(pull(0.0))
    assert float(law.kappa(g)) == pytest.approx(kappa, rel=1e-5)
    x, x_hi = _B(g) / _B(G_LO), _B(G_HI) / _B(G_LO)
    i_d = 3.0
    u = x * (1 - kappa * i_d)
    s = ((1 - math.exp(-u)) / u) / ((1 - math.exp(-x_hi)) / x_hi)
    # in the rig: every magnetic term scaled by s^2 (both fields saturate)
    rig = Rig(NOMINAL, [law], RigSettings.ideal(nominal_cogging=False))
    a_up, _ = rig.magnetic(np.array([g]), np.array([0.0]), np.array([0.0]), np.array([i_d]), 1.0)
    sh = shape(g)
    want = (NOMINAL.C2 * sh.f2 - NOMINAL.C3 * sh.f3 * i_d + NOMINAL.C4 * sh.f4 * i_d**2) * s * s
    assert a_up[0] == pytest.approx(float(want), rel=1e-5)
    # more levitation current weakens the flux: less saturation
    assert law.loss(np.array([g]), 4.0)[0] < law.loss(np.array([g]), 0.0)[0]


# ------------------------------------------------------------------- amplifier and delay
def _freq(law, w):
    A, B, C = law.ss(0)
    return C @ np.linalg.solve(1j * w * np.eye(A.shape[0]) - A, B[:, 0])


def test_symmetric_optimum_response():
    T = 3e-4
    law = make_law("amplifier_lag", {"family": "symmetric_optimum", "t_sigma": T})
    tf = signal.TransferFunction([4 * T, 1], [8 * T**3, 8 * T**2, 4 * T, 1])
    t = np.linspace(0, 40 * T, 400)
    _, y = signal.step(tf, T=t)
    for j in (40, 120, 399):
        _, Bd = law.discrete(0, t[j])
        assert (Bd @ np.array([1.0, 0.0])) @ law.ss(0)[2] == pytest.approx(y[j], abs=1e-6)
    assert 1.40 < y.max() < 1.46  # Kessler: about 43 % overshoot
    for w in (100.0, 1000.0, 3000.0):
        assert _freq(law, w) == pytest.approx(complex(np.polyval(tf.num, 1j * w) / np.polyval(tf.den, 1j * w)))


def test_eddy_diffusion_is_the_slab_response():
    # (1 - m) + m tanh(sqrt(s tau)) / sqrt(s tau), behind wc / (s + wc): six modes within 2 %
    tau, m, bw = 8e-3, 0.4, 2000.0
    law = make_law("amplifier_lag", {"family": "eddy_diffusion", "tau_e": tau, "m": m, "bandwidth_hz": bw})
    wc = 2 * math.pi * bw
    for w in (0.3 / tau, 1 / tau, 3 / tau, 30 / tau):
        z = np.sqrt(1j * w * tau)
        want = ((1 - m) + m * np.tanh(z) / z) * wc / (1j * w + wc)
        assert abs(_freq(law, w) - want) < 0.02
    assert law.group_delay(1e-3) == pytest.approx(1 / wc + m * tau / 3, rel=0.02)


# ------------------------------------------------------------------------- commutation
def test_field_angle_matches_the_array_field():
    # field direction of the alternating array (magnet width taup, height hm) summed to n = 41 here:
    # B_y + i B_x ~ sum_n (sin(n pi taup / 2 tau) / n) (1 - e^{-n K hm}) e^{-n K y} e^{i n theta}
    law = make_law("commutation_offset", {"family": "field_angle", "delta0": 0.01, "c_s": 8e-3, "x0": 0.004})
    g, d = 0.014, np.linspace(-0.05, 0.05, 37)
    th = KP * (d - 0.004)
    y = g + 8e-3
    z = sum(
        math.sin(n * math.pi * k.taup / (2 * k.tau)) / n * (1 - math.exp(-n * KP * k.hm)) * math.exp(-n * KP * y)
        * np.exp(1j * n * th)
        for n in range(1, 42, 2)
    )  # fmt: skip
    want = 0.01 + np.angle(z * np.exp(-1j * th))
    assert law.angle(d, 0.0, g) == pytest.approx(want, abs=2e-3)
    amp = [np.ptp(law.angle(np.linspace(0, 2 * k.tau, 400), 0.0, gg)) for gg in (0.012, 0.02)]
    assert amp[0] > 1.5 * amp[1]  # the error shrinks as the gap opens
    X = np.zeros((1, 6))
    X[0, 0], X[0, 2] = 0.014, 0.01
    iq, idd = law.rotate_at(np.array([1.0]), np.array([2.0]), X, None)
    assert math.hypot(iq[0], idd[0]) == pytest.approx(math.sqrt(5), rel=1e-12)


def test_hall_hysteresis_lags_by_half_the_band_in_the_direction_of_motion():
    law = make_law("commutation_offset", {"family": "hall_hysteresis", "delta0": 0.02, "x_h": 1.5e-3, "v_r": 1e-3})
    half = math.pi * 1.5e-3 / (2 * k.tau)
    assert law.angle(0.0, np.array([0.1, -0.1, 0.0])) == pytest.approx([0.02 + half, 0.02 - half, 0.02], abs=1e-12)


# --------------------------------------------------------------------------- eddy drag
def test_solid_iron_skin_factor_from_the_diffusion_in_the_plate():
    # loss in a plate of thickness t carrying a fixed mean flux: B(x) = Bs cosh(kx) / cosh(kt/2), k = (1+i)/delta,
    # E = i w int B dx; the loss over its low-frequency value (E = i w B x) by quadrature
    law = make_law("eddy_drag", {"family": "solid_iron", "c0": 5.0, "t_p": 1e-2, "mu_r": 500.0, "sigma": 5e6})
    t = 1e-2
    for v in (0.05, 0.3):
        xi = float(law.xi(np.array([v]))[0])
        delta = t / xi
        kk = (1 + 1j) / delta
        bs = 1.0 / (np.tanh(kk * t / 2) / (kk * t / 2))  # mean flux 1

        def e_sq(x, kk=kk, bs=bs):
            return abs(bs * np.sinh(kk * x) / (kk * np.cosh(kk * t / 2))) ** 2

        e2 = integrate.quad(e_sq, -t / 2, t / 2)[0]
        ratio = e2 / (t**3 / 12)
        fd = law.force(np.array([k.g_cog_ref]), 0, 0, np.array([v]))[1][0]
        assert -fd / (5.0 * v) == pytest.approx(ratio, rel=1e-6)
    # low speed: viscous, scaled by MODEL.md's B(g)^2
    fd = law.force(np.array([0.02]), 0, 0, np.array([1e-4]))[1][0]
    assert fd == pytest.approx(-5.0 * 1e-4 * (_B(0.02) / _B(k.g_cog_ref)) ** 2, rel=1e-6)


def test_sheet_damps_both_axes_alike_and_is_reitz_along_d():
    law = make_law("eddy_drag", {"family": "sheet_2axis", "c0": 6.0, "T": 1e-3, "sigma": 3.5e7})
    w = 2 / (4e-7 * math.pi * 3.5e7 * 1e-3)
    # Faraday: |dB/dt| of B = e^{-K g} cos(K x) is the same per unit speed along x and along g (rms over x)
    x = np.linspace(0, 2 * k.tau, 1000, endpoint=False)
    dbdt_x = KP * np.sin(KP * x)
    dbdt_g = -KP * np.cos(KP * x)
    assert np.sqrt(np.mean(dbdt_x**2)) == pytest.approx(np.sqrt(np.mean(dbdt_g**2)), rel=1e-12)
    fg, _ = law.force(np.array([0.015]), np.array([1e-3]), 0, np.array([0.0]))
    _, fd = law.force(np.array([0.015]), np.array([0.0]), 0, np.array([1e-3]))
    assert fg[0] == pytest.approx(fd[0], rel=1e-6)
    c = 6.0 * math.exp(-2 * KP * 0.005)
    _, fd = law.force(np.array([0.015]), 0, 0, np.array([w]))  # Reitz: the drag peaks at v = w with c w / 2
    assert fd[0] == pytest.approx(-c * w / 2, rel=1e-12)


# --------------------------------------------------------------------- out of the library
def test_mount_rings_after_a_velocity_step():
    # q'' + 2 zeta w q' + w^2 q = -v': a step V gives q = -(V / wd) e^{-zeta w t} sin(wd t)
    law = make_law("mount_resonance", {"family": "read_head", "f_hz": 50.0, "zeta": 0.02})
    law.reset(1)
    V, h = 0.1, 1e-4
    w = 2 * math.pi * 50.0
    wd = w * math.sqrt(1 - 0.02**2)
    for n in range(1, 121):
        fg, fd = law.held(np.array([0.0]), np.array([V]), h)
        t = n * h
        assert law.read(np.array([0.02]), np.array([0.0]))[1][0] == pytest.approx(
            -(V / wd) * math.exp(-0.02 * w * t) * math.sin(wd * t), abs=1e-10
        )
    assert fd[0] == 0.0 and fg[0] == 0.0
    assert law.recorded()["peak_error_d_m"] == pytest.approx(V / wd * math.exp(-0.02 * w * 0.25 / 50), rel=0.02)


def test_coil_heating_first_order_warmup():
    law = make_law("coil_heating", {"family": "first_order", "R": 3.0, "R_th": 0.8, "tau_th": 30.0, "kappa": 4e-6})
    law.reset(2)
    i = np.array([[0.0, 2.0], [1.0, 2.0]])
    Tss = 0.8 * 1.5 * 3.0 * np.array([4.0, 5.0])
    law.advance(i, np.array([0.0, 10.0]), 1e-3)  # run 1 starts after 10 s of its predecessor's losses
    assert law.T == pytest.approx([0.0, Tss[1] * (1 - math.exp(-10 / 30))], rel=1e-12)
    for _ in range(5000):
        law.advance(i, None, 1e-3)
    assert law.T[0] == pytest.approx(Tss[0] * (1 - math.exp(-5 / 30)), rel=1e-9)
    g, _ = law.read(np.array([0.02, 0.02]), np.array([0.0, 0.0]))
    assert g - 0.02 == pytest.approx(4e-6 * law.T, rel=1e-12)


# ------------------------------------------------------------------------------ drawing
def test_every_drawn_v4_law_is_finite_and_bounded_and_every_family_is_drawn():
    seen = set()
    g, d, v = envelope_grid()
    X = np.column_stack([g, v, d, v, 0 * g, 0 * g])
    for seed in range(120):
        sc = draw(seed, laws="v4")
        assert sc == draw(seed, laws="v4")
        for name, spec in sc["effects"].items():
            law = make_law(name, spec)
            assert spec["new_law"] and law.describe()["law_set"] == "v4"
            seen.add((name, law.family))
            check_law_over_envelope(law, (name, spec), factor_band=(0.5, 1.5))
            if law.has_factors_i:
                for i_d in (-8.0, 0.0, 8.0):
                    f = [np.ones_like(g) for _ in range(4)]
                    law.factors_i(g, d, 0 * g, 0 * g + i_d, f)
                    assert all(np.all((x > 0.5) & (x < 1.5)) for x in f), (name, spec)
            if law.has_rotate_at:
                a = law.angle(d, v, g)
                assert np.all(np.isfinite(a)) and np.max(np.abs(a)) < 0.3, (name, spec)
                iq, idd = law.rotate_at(0 * g + 1.0, 0 * g + 2.0, X, None)
                assert np.allclose(iq**2 + idd**2, 5.0)
    assert seen == {(n, f) for n, c in V4_LAWS.items() for f in c.families}


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v3_and_resonance_datasets_are_the_same_bytes_as_before(tmp_path):
    # whole folders (runs, dataset.yaml, truth.json) recorded at commit 934155e with the same call, per SIMD level
    # (rig_bytes): X86_V4 on the AVX512 CI machine; X86_V3 the same at 934155e and ac59446 on an AMD EPYC (numpy
    # 2.4.6); elsewhere the unquantized call against data/rig_digests.json
    cases = {
        "v3": (
            {
                "amplifier_lag": {"family": "pi_backemf"},
                "commutation_offset": {"family": "latency"},
                "gap_sensor_drift": None,
            },
            11,
            {
                "X86_V4": "f475287988d5dd79385193a476b207e0190f6f3b2fbafea05bf61f538fbb2689",
                "X86_V3": "1441ee31b7ea297f77e8bd1e01bc56dc433f278019e4bbd14a9baf0ab185dc44",
            },
        ),
        "ool": (
            {"resonance": None},
            7,
            {
                "X86_V4": "b9525baaa5a8d55e022b6973ab57c2926f4d46e41b3436a99cb6254b9a56c1f4",
                "X86_V3": "9000e1761a676de0248cf78abb8651e4455deee5d20fe97055d54b2ce70f18fd",
            },
        ),
    }
    assert_same_datasets(tmp_path, cases, "v4")


@pytest.mark.long  # an earlier set's regression: `make check-long` (CI runs the latest set's)
def test_v4_generation_is_deterministic_and_records_sizes(tmp_path):
    effects = {
        "amplifier_lag": {"family": "eddy_diffusion"},
        "saturation": {"family": "dq_flux"},
        "coil_heating": {"family": "first_order", "R_th": 1.0},
    }
    s = RigSettings(n_runs=2, duration=2.0)
    a = generate(tmp_path / "a", effects, seed=11, settings=s)
    b = generate(tmp_path / "b", effects, seed=11, settings=s)
    assert dataset_hash(a) == dataset_hash(b)
    truth = json.loads((a / "truth.json").read_text())
    assert truth["expected_verdict"] == "amplifier_lag+saturation"
    assert all(e["law_set"] == "v4" for e in truth["effects"].values())
    amp = make_law("amplifier_lag", {"family": "eddy_diffusion"})
    assert truth["effects"]["amplifier_lag"]["effective_delay_s"] == pytest.approx(amp.group_delay(1e-3))
    assert truth["effects"]["saturation"]["peak_force_n"] > 0.5
    assert truth["effects"]["coil_heating"]["peak_rise_k"] > 1.0
    assert truth["hover_error_rms_m"]["g"] < 1e-4 and truth["hover_error_rms_m"]["d"] < 3e-4  # still controlled
