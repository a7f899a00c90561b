"""C code generation of the controllers, and the compiled (``backend: c``) controllers.

The controllers' steps are CasADi Functions; this package turns them into
self-contained C with CasADi's code generator and brings the compiled code
back into the Python closed loop.

Modules
-------
observer_fn
    The high-gain observer update as a CasADi Function.
fl_fn
    Feedback linearization's whole step (observer + law) as CasADi Functions.
functions
    What is generated per controller (:class:`ControllerCode`: Functions, documented ports).
sources
    Writing the folder: ``<fn>.c/.h``, ``maglev_controller.h``, ``main.c``, ``Makefile``,
    ``CMakeLists.txt``, ``README.md``, ``manifest.json``.
build
    ``make`` in a folder and the content-hash build cache.
loader
    ctypes calls into the compiled library.
backend
    The compiled step evaluators (:func:`~.backend.c_evaluators`, injected into the
    NMPC) and the runner's ``backend: c`` builder (:func:`~.backend.build_c_controller`),
    registered with :func:`maglev_ocp.runner.register_backend` when this package is imported.

Example
-------
>>> from maglev_ocp.codegen import generate_controllers            # doctest: +SKIP
>>> src = generate_controllers(["nmpc", "fl", "observer"])           # doctest: +SKIP
>>> src.save("build/controller_c"); print(src.table())               # doctest: +SKIP
"""

from __future__ import annotations

from typing import Any

from maglev_ocp.controllers.fl import FLSettings
from maglev_ocp.controllers.nmpc import NMPCSettings

from ..params import NOMINAL, Params
from .backend import register_c_backend
from .functions import KINDS, ControllerCode, fl_code, nmpc_code, observer_code, resolve_nmpc_mode
from .sources import GeneratedSources, generate_sources
from .templates import DEFAULT_CFLAGS


def controller_codes(
    kinds=KINDS,
    params: Params = NOMINAL,
    nmpc_settings: Any = None,
    fl_settings: Any = None,
    shaping: str | None = "trajectory",
) -> list[ControllerCode]:
    """The :class:`ControllerCode` of each controller in ``kinds``.

    Parameters
    ----------
    kinds : sequence of str
        Among ``nmpc``, ``fl``, ``observer``.
    params : Params
        What the controllers' models believe.
    nmpc_settings, fl_settings : settings models, optional
        Default: the controllers' defaults.
    shaping : str or None
        The scenario's ``reference.shaping`` (decides the NMPC's ``auto`` reference
        mode as the runner would); ``None``: no runner reference (plan mode).
    """
    out = []
    for kind in kinds:
        if kind == "nmpc":
            s = nmpc_settings or NMPCSettings()
            out.append(nmpc_code(s, params, resolve_nmpc_mode(s, shaping)))
        elif kind == "fl":
            out.append(fl_code(fl_settings or FLSettings(), params))
        elif kind == "observer":
            fs = fl_settings or FLSettings()
            out.append(observer_code(fs.observer_eps, fs.disturbance, params))
        else:
            raise ValueError(f"unknown controller kind {kind!r} (choose from {', '.join(KINDS)})")
    return out


def generate_controllers(kinds=KINDS, cflags: str = DEFAULT_CFLAGS, **designs: Any) -> GeneratedSources:
    """Generate the folder's files for ``kinds``; nothing written yet.

    ``designs`` are :func:`controller_codes`'s other arguments (``params``, ``nmpc_settings``,
    ``fl_settings``, ``shaping``); ``cflags`` the Makefile's default compiler flags.
    """
    return generate_sources(controller_codes(kinds, **designs), cflags)


register_c_backend()


__all__ = ["DEFAULT_CFLAGS", "KINDS", "ControllerCode", "GeneratedSources", "controller_codes", "generate_controllers"]
