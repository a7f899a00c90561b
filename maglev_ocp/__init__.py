"""maglev-ocp: nonlinear MPC and optimal-control design suite for a 2-DOF PMLSM maglev stage.

The one shared symbolic model is :func:`maglev_ocp.model.get_model`; parameters
are :class:`maglev_ocp.params.Params`.
"""

import importlib
from typing import Any

# The shared names load lazily (PEP 562): ``import maglev_ocp.cli`` must not import CasADi before the CLI
# has installed its interrupt handler (a Ctrl-C during start-up is then one line, not a traceback).
_LAZY = {
    "MaglevModel": ".model",
    "get_model": ".model",
    "NOMINAL": ".params",
    "Params": ".params",
    "load_params": ".params",
}


def __getattr__(name: str) -> Any:
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["NOMINAL", "MaglevModel", "Params", "get_model", "load_params"]
__version__ = "0.1.0"
