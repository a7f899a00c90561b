"""OSQP's own embedded code for the NMPC's QP (``solver: osqp`` with ``osqp: {embedded: true}``).

The QP is :class:`~maglev_ocp.controllers.nmpc.osqp_solver.OSQPStage`'s (box, circumscribed
polygon and cutting-plane passes on the current disks, soft gap rows with
slacks), with the same fixed sparsity. Its Hessian ``H``, gap rows ``G`` and
cut normals change every step (the RTI linearization and the cut directions),
so the vectors alone are not enough: the code is generated with OSQP's
``codegen(parameters="matrices")`` (embedded mode 2), in which ``P.x`` and
``A.x`` are parameters and every update rescales the data and refactorizes
the KKT matrix numerically (its symbolic pattern and ordering are fixed at
generation). Embedded mode has no polishing (OSQP builds it only into the
full library), so the generated solver stops at ``eps_abs``/``eps_rel``
(tighter by default than the polished package's; :class:`OSQPOptions`).

The generated C (OSQP's sources, ``workspace.c`` with the problem's sparsity,
scaling and settings, and a three-function glue file that only calls OSQP's
API) is compiled once per design into a shared library, cached by content
hash under ``$MAGLEV_CODEGEN_CACHE`` (default ``~/.cache/maglev-ocp/codegen``)
like the controllers' C, and each stage loads its own copy (the workspace is
a global of the library: two stages must not share warm starts). The glue is
called through ``ctypes`` by :class:`~maglev_ocp.controllers.nmpc.osqp_solver.EmbeddedOSQPStage`;
the cutting-plane passes stay in ``OSQPStage.solve``, shared with the package path.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

#: Compiler flags of the generated solver (no fast-math: OSQP's own arithmetic, in order).
CFLAGS = ("-O2", "-fPIC", "-ffp-contract=off")

#: The glue the stage calls: data in, solution and status out; nothing but OSQP's API (``osqp_api_functions.h``).
GLUE_C = r"""
#include "osqp.h"
#include "workspace.h"

/* a new QP (or a new cut set): vectors, then the matrices' values in their fixed sparsity (NULL: keep) */
int nmpc_osqp_update(const OSQPFloat *q, const OSQPFloat *l, const OSQPFloat *u, const OSQPFloat *Px,
                     const OSQPFloat *Ax) {
  OSQPInt e = osqp_update_data_vec(&solver, q, l, u);
  if (e) return (int)e;
  if (Px || Ax) e = osqp_update_data_mat(&solver, Px, OSQP_NULL, 0, Ax, OSQP_NULL, 0);
  return (int)e;
}

/* solve from the last solution (warm start); x (n) and info = (status, iterations, r_prim, r_dual) */
int nmpc_osqp_solve(OSQPFloat *x, OSQPFloat *info) {
  OSQPInt e = osqp_solve(&solver), m, n, i;
  osqp_get_dimensions(&solver, &m, &n);
  for (i = 0; i < n; i++) x[i] = solver.solution->x[i];
  info[0] = (OSQPFloat)solver.info->status_val;
  info[1] = (OSQPFloat)solver.info->iter;
  info[2] = solver.info->prim_res;
  info[3] = solver.info->dual_res;
  return (int)e;
}

int nmpc_osqp_n(void) {
  OSQPInt m, n;
  osqp_get_dimensions(&solver, &m, &n);
  return (int)n;
}
"""


def _cache_root() -> Path:
    """Root of the build cache: ``$MAGLEV_CODEGEN_CACHE`` or ``~/.cache/maglev-ocp/codegen`` (the controllers')."""
    env = os.environ.get("MAGLEV_CODEGEN_CACHE")
    return Path(env) if env else Path.home() / ".cache" / "maglev-ocp" / "codegen"


def _compiler() -> str:
    for cand in (os.environ.get("CC"), "cc", "gcc", "clang"):
        if cand and shutil.which(cand):
            return cand
    raise RuntimeError("solver: osqp with osqp.embedded: true needs a C compiler (cc, gcc or clang; or set CC)")


def osqp_setup(P, q, A, lo, hi, opts, polishing: bool):
    """An ``osqp.OSQP`` set up on the NMPC's QP with the settings ``opts`` (``NMPCSettings.osqp``).

    The one setup of both OSQP paths: the package solver of
    :class:`~maglev_ocp.controllers.nmpc.osqp_solver.OSQPStage` and the placeholder
    problem :func:`generate` hands to OSQP's code generator (warm starts on,
    quiet; polishing only where the variant has it).
    """
    import osqp

    m = osqp.OSQP()
    m.setup(
        P,
        q,
        A,
        lo,
        hi,
        verbose=False,
        eps_abs=opts.abs_tolerance,
        eps_rel=opts.rel_tolerance,
        max_iter=opts.max_iter,
        polishing=polishing,
        warm_starting=True,
    )
    return m


def generate(stage, folder: Path) -> None:
    """Write OSQP's embedded code (mode 2) for ``stage``'s QP into ``folder``, plus :data:`GLUE_C`.

    ``stage`` is a :class:`~maglev_ocp.controllers.nmpc.osqp_solver.OSQPStage` (its sparsity, bounds and options).

    The solver is set up on a placeholder QP with the stage's sparsity (identity Hessian, zero gap
    rows, the polygon's normals); only the sparsity, the settings and the dimensions matter, every
    value is replaced at the first update.
    """

    o = stage.opts
    N, nv, ng = stage.N, stage.nv, stage.ng
    normals = stage.initial_normals(np.zeros((N, 2)))
    px, ax = stage._values(np.eye(nv), np.zeros((ng, nv)), normals)
    P, A = stage._matrices_of(px, ax)
    lo, hi = stage._bounds(np.zeros(nv), -np.ones(ng), np.ones(ng), normals)
    m = osqp_setup(P, np.zeros(nv + ng), A, lo, hi, o, polishing=False)
    m.codegen(str(folder), parameters="matrices", extension_name=None, force_rewrite=True)
    (folder / "nmpc_osqp_glue.c").write_text(GLUE_C)


def _design_hash(folder: Path, cc: str) -> str:
    """Content hash of the generated folder (``workspace.c`` without its date line), compiler and flags."""
    import osqp

    h = hashlib.sha256()
    for name in ("workspace.c", "workspace.h", "osqp_configure.h", "nmpc_osqp_glue.c"):
        text = (folder / name).read_text()
        h.update("\n".join(ln for ln in text.splitlines() if "autogenerated by OSQP on" not in ln).encode())
    h.update(f"{osqp.__version__}|{cc}|{' '.join(CFLAGS)}".encode())
    return h.hexdigest()[:20]


def build(stage, progress: bool = False) -> Path:
    """The shared library of ``stage``'s embedded solver: from the cache, else generated and compiled there."""
    from tqdm import tqdm

    cc = _compiler()
    root = _cache_root()
    root.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="osqp-build-", dir=root))
    try:
        generate(stage, tmp)
        final = root / f"osqp-{_design_hash(tmp, cc)}"
        lib = final / "libnmpc_osqp.so"
        if lib.exists():
            return lib
        inc = ["-I" + str(tmp / "inc" / "public"), "-I" + str(tmp / "inc" / "private"), "-I" + str(tmp)]
        sources = [*sorted((tmp / "src").glob("*.c")), tmp / "workspace.c", tmp / "nmpc_osqp_glue.c"]
        objs = []
        for src in tqdm(sources, desc="osqp codegen", unit="file", disable=not progress, leave=False):
            obj = src.with_suffix(".o")
            _run([cc, *CFLAGS, *inc, "-c", str(src), "-o", str(obj)])
            objs.append(str(obj))
        _run([cc, "-shared", "-o", str(tmp / "libnmpc_osqp.so"), *objs, "-lm"])
        try:
            tmp.rename(final)  # atomic: another process may have built the same design meanwhile
        except OSError:
            if not lib.exists():
                raise
        return lib
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def _run(cmd: list[str]) -> None:
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"building OSQP's embedded code failed: {' '.join(cmd[:3])} ...\n{r.stderr[-2000:]}")


def load(stage, progress: bool = False) -> tuple[Path, ctypes.CDLL]:
    """Build (or find) ``stage``'s library and load a private copy: ``(cached library, loaded copy)``.

    Each stage gets its own copy because the workspace is a global of the library and ``dlopen``
    shares one per path; the copy is mapped, so its file is removed at once.
    """
    lib = build(stage, progress)
    tmp = tempfile.mkdtemp(prefix="nmpc-osqp-")
    try:
        own = Path(tmp, lib.name)
        shutil.copyfile(lib, own)
        handle = ctypes.CDLL(str(own))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    dp = ctypes.POINTER(ctypes.c_double)
    for fn in (handle.nmpc_osqp_update, handle.nmpc_osqp_solve, handle.nmpc_osqp_n):
        fn.restype = ctypes.c_int
    handle.nmpc_osqp_update.argtypes = [dp] * 5
    handle.nmpc_osqp_solve.argtypes = [dp, dp]
    return lib, handle


__all__ = ["CFLAGS", "GLUE_C", "build", "generate", "load"]
