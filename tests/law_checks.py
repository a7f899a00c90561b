"""A drawn rigsim law evaluated over the rig's envelope, for the law-set tests (test_rigsim_laws_new/_v3).

One helper so that every law set is held to the same check: finite forces, bounded by a force no effect of
this rig can reach (the pull is about 100 N; 50 N is half of it), multiplicative factors near 1, and readings
that stay within a millimetre of the true position.
"""

from __future__ import annotations

import numpy as np

from maglev_ocp import constants as k

#: Largest force any drawn effect may apply over the envelope [N] (the magnets' pull is ~ 100 N).
FORCE_BOUND_N = 50.0


def envelope_grid(n: int = 9) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Gap, position and velocity over the stops and +-60 mm, +-0.5 m/s, ``n`` points each, flattened."""
    g_lo, g_hi = k.g_stop
    g, d, v = np.meshgrid(np.linspace(g_lo, g_hi, n), np.linspace(-0.06, 0.06, n), np.linspace(-0.5, 0.5, n))
    return g.ravel(), d.ravel(), v.ravel()


def check_law_over_envelope(law, label: object, factor_band: tuple[float, float], read_tol_m: float = 1e-3) -> None:
    """Assert that ``law``'s force (static and held, after 20 steps of 0.1 ms) is finite and below
    :data:`FORCE_BOUND_N`, its factors inside ``factor_band`` and its readings within ``read_tol_m``."""
    g, d, v = envelope_grid()
    law.reset(g.size)
    fg = fd = np.zeros_like(g)
    if law.has_force:
        fg, fd = law.force(g, v, d, v)
    if law.has_held:
        for _ in range(20):
            hg, hd = law.held(v, v, 1e-4)
        fg, fd = fg + hg, fd + hd
    assert np.all(np.isfinite(fg)) and np.all(np.isfinite(fd)), label
    assert np.max(np.abs(fg)) < FORCE_BOUND_N and np.max(np.abs(fd)) < FORCE_BOUND_N, label
    if law.has_factors:
        f = [np.ones_like(g) for _ in range(4)]
        law.factors(g, d, f)
        lo, hi = factor_band
        assert all(np.all((x > lo) & (x < hi)) for x in f), label
    if getattr(law, "has_read", False):
        gr, dr = law.read(g, d)
        assert np.max(np.abs(gr - g)) < read_tol_m and np.max(np.abs(dr - d)) < read_tol_m, label
