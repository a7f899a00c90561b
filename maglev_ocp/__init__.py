"""maglev-ocp: nonlinear MPC and optimal-control design suite for a 2-DOF PMLSM maglev stage.

The one shared symbolic model is :func:`maglev_ocp.model.get_model`; parameters
are :class:`maglev_ocp.params.Params`.
"""

from .model import MaglevModel, get_model
from .params import NOMINAL, Params, load_params

__all__ = ["NOMINAL", "MaglevModel", "Params", "get_model", "load_params"]
__version__ = "0.1.0"
