"""Shared pytest fixtures."""

from __future__ import annotations

import os

import matplotlib
import pytest

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture(scope="session")
def model():
    """The shared symbolic model (built once per test session)."""
    from maglev_ocp.model import get_model

    return get_model()


@pytest.fixture(scope="session")
def p_nom():
    """Nominal parameter vector (seed Table III, spec cogging law)."""
    from maglev_ocp.params import NOMINAL

    return NOMINAL.vector()
