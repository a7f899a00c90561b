"""The package users import: settings validation apart from output and SIGINT handling, old imports still work."""

from __future__ import annotations

import importlib

import pytest


def test_config_holds_validation_only():
    config = importlib.import_module("maglev_ocp.config")
    output = importlib.import_module("maglev_ocp.output")
    for name in ("replace_dir", "atomic_write_text", "check_output_dir", "dump_yaml"):
        assert name not in vars(config), name  # not defined in config any more
        assert callable(getattr(output, name))
    assert callable(importlib.import_module("maglev_ocp.interrupts").sigint_ignored)


def test_old_imports_from_config_still_work_with_a_deprecation_warning():
    from maglev_ocp import output

    with pytest.warns(DeprecationWarning, match=r"maglev_ocp\.output\.replace_dir"):
        from maglev_ocp.config import replace_dir
    assert replace_dir is output.replace_dir
    with pytest.raises(AttributeError):
        importlib.import_module("maglev_ocp.config").no_such_name  # noqa: B018
