"""The blind self-check draws the independent rig's effects from the law set it is told (``--laws``).

Issue 27's pre-registered checks run the diagnosis on law families it was not written from; the third set
(:mod:`maglev_ocp.rigsim.laws_v3`) is reached through ``maglev diagnose selftest --generator independent
--laws v3``, the fourth (:mod:`maglev_ocp.rigsim.laws_v4`) through ``--laws v4``. These tests check the wiring
without running a diagnosis: the setting is validated, the library generator refuses it in one line, and the
drawn cases of a ``v3`` / ``v4`` check carry only that set's laws.
"""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from maglev_ocp.cli import main
from maglev_ocp.diagnosis.selftest import SelftestSettings
from maglev_ocp.rigsim import draw
from maglev_ocp.rigsim.laws_v3 import V3_LAWS
from maglev_ocp.rigsim.laws_v4 import V4_LAWS


def test_an_unknown_law_set_is_refused():
    with pytest.raises(ValidationError, match="laws"):
        SelftestSettings(laws="no-such-set")
    assert SelftestSettings(laws="v4").laws == "v4"


def test_an_unknown_law_set_is_refused_on_the_command_line(capsys):
    """``--laws`` takes the rig's registered sets (``rigsim.draw.LAW_SETS``, no list of its own): anything else is
    one line naming what is allowed, exit 2, before any dataset is drawn."""
    from maglev_ocp.rigsim.draw import LAW_SETS

    rc = main(["diagnose", "selftest", "2", "--generator", "independent", "--laws", "v999"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and "v999" in err[0] and all(s in err[0] for s in LAW_SETS), err


def test_the_library_generator_refuses_a_law_set(capsys):
    rc = main(["diagnose", "selftest", "2", "--laws", "v3"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and "--generator independent" in err[0]


@pytest.mark.parametrize("seed", range(12))
def test_a_v3_draw_holds_only_v3_families(seed):
    scen = draw(seed, laws="v3")
    for name, spec in scen["effects"].items():
        assert spec["family"] in V3_LAWS[name].families, (name, spec["family"])
        assert spec["new_law"] is True


@pytest.mark.parametrize("seed", range(12))
def test_a_v4_draw_holds_only_v4_families(seed):
    scen = draw(seed, laws="v4")
    for name, spec in scen["effects"].items():
        assert spec["family"] in V4_LAWS[name].families, (name, spec["family"])
        assert spec["new_law"] is True
