"""A diagnosis of a plant with one effect whose law is no library member names that effect and no flexible
member of another effect beside it (issue 27, item 2: no effect claimed that is not there).

The law is written here from its physics source, as a force added to the simulated rig
(:func:`maglev_ocp.diagnosis.generate.generate_dataset`, ``extra_force``): friction with Tustin's exponential
Stribeck curve (Armstrong-Helouvry, Dupont and Canudas de Wit, Automatica 30(7), 1994, eq. (4)); the
library's Stribeck member has a Gaussian one and its learned member a spline, so no member is the law.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from maglev_ocp.diagnosis import DiagnoseSettings, diagnose
from maglev_ocp.diagnosis.generate import GeneratorSettings, generate_dataset
from maglev_ocp.diagnosis.selftest import selftest_plant
from maglev_ocp.params import NOMINAL

BASE = NOMINAL.without_cogging()


def _tustin(t: float, x: np.ndarray) -> np.ndarray:
    """Tustin friction [N] on both guides: ``-(Fc + Fs exp(-|v| / 2 mm/s)) sign(v) - b v``, sign smoothed at
    0.2 mm/s (vertical Fc 0.3 N, Fs 0.3 N, b 2 N s/m; horizontal 0.4 N, 0.5 N, 3 N s/m)."""
    out = np.zeros(2)
    for j, (v, fc, fs, b) in enumerate(((x[1], 0.3, 0.3, 2.0), (x[3], 0.4, 0.5, 3.0))):
        out[j] = -(fc + fs * math.exp(-abs(v) / 2e-3)) * math.tanh(v / 2e-4) - b * v
    return out


@pytest.mark.slow
@pytest.mark.timeout(900)
def test_tustin_friction_is_named_friction_and_no_other_flexible_member_is_added() -> None:
    cfg = selftest_plant("given", {})
    gen = generate_dataset(cfg, BASE, seed=41, settings=GeneratorSettings(n_runs=4, run_duration=7.0),
                           extra_force=_tustin)  # fmt: skip
    d = diagnose(gen.dataset, params=BASE, settings=DiagnoseSettings(simulate=False))
    assert "friction" in d.effects_found, d.table()
    others = [s for s in d.scores if s.selected and s.name.split("[")[0] != "friction"]
    flexible = [s.name for s in others if s.fit is not None and s.fit.spec.flexible]
    assert not flexible, d.table()
    assert set(d.effects_found) == {"friction"}, d.table()
