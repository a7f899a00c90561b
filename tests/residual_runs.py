"""A residual of the diagnosis built from features and a residual written in a test (shared by the signature tests)."""

from __future__ import annotations

import numpy as np
import scipy.sparse as spa

from maglev_ocp.diagnosis.residuals import PreparedRun, Residual


def feature_residual(name: str, feat: dict[str, np.ndarray], force, noise: float,
                     rng: np.random.Generator) -> Residual:  # fmt: skip
    """A held-out-like run's residual ``force(feat, channel) + noise`` (white, rms ``noise``) at the features
    ``feat`` (the keys of :attr:`PreparedRun.feat`), with the current rates added as the features' gradients."""
    t = feat["t"]
    feat["di_q"] = np.gradient(feat["i_q"], t)
    feat["di_d"] = np.gradient(feat["i_d"], t)
    n = len(t)
    r = np.column_stack([force(feat, 0), force(feat, 1)]) + noise * rng.standard_normal((n, 2))
    run = PreparedRun(name, (), np.array([True, True]), np.zeros((n, 8)), spa.csr_matrix((n, n)), r, np.arange(n),
                      feat)  # fmt: skip
    return Residual(run, r, np.zeros_like(r))
