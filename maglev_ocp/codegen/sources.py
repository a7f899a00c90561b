"""Writing the generated folder: C sources, header, harness, Makefile, CMakeLists, manifest.

:func:`generate_sources` turns :class:`~maglev_ocp.codegen.functions.ControllerCode`
objects into text files (CasADi's :class:`casadi.CodeGenerator`, one C file per
function so that ``make -j`` compiles them in parallel), and
:class:`GeneratedSources` holds them in memory (content hash for the build
cache) until :meth:`GeneratedSources.save` writes them atomically.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from .. import constants as k
from ..output import atomic_write_text
from . import templates as tpl
from .functions import CodeUnit, ControllerCode, Port

#: CasADi code-generator options: header per file, explicit scalar types, and no
#: dependence on a memory object (the step functions have no persistent memory).
CODEGEN_OPTIONS: dict = {
    "with_header": True,
    "casadi_real": "double",
    "casadi_int": "long long int",
    "with_mem": False,
    "verbose_runtime": False,
}


def _macro(*parts: str) -> str:
    return "_".join(re.sub(r"[^A-Za-z0-9]", "_", p).upper() for p in parts if p)


def _c_number(v: float) -> str:
    return repr(float(v)) if np.isfinite(v) else ("NAN" if np.isnan(v) else ("INFINITY" if v > 0 else "-INFINITY"))


def generate_function_source(fn: ca.Function) -> tuple[str, str]:
    """C source and header text of one Function (CasADi's code generator, :data:`CODEGEN_OPTIONS`)."""
    with tempfile.TemporaryDirectory(prefix="maglev-cg-") as tmp:
        cg = ca.CodeGenerator(f"{fn.name()}.c", dict(CODEGEN_OPTIONS))
        cg.add(fn)
        cg.generate(tmp + os.sep)
        c = Path(tmp, f"{fn.name()}.c").read_text()
        h = Path(tmp, f"{fn.name()}.h").read_text()
    return _static_helpers(c), h


def _static_helpers(src: str) -> str:
    """Give CasADi's auxiliary routines (``casadi_sq``, ``casadi_fmax``, ``casadi_copy``, ...) internal linkage.

    The code generator defines them with external linkage (under a per-file
    prefix); compiled with ``-fPIC`` into the shared library, every call of
    such a one-line helper then goes through the PLT and cannot be inlined.
    ``static`` changes nothing computed, and lets any compiler inline them.
    """
    return re.sub(r"^(casadi_real|casadi_int|void|int) (casadi_\w+\()", r"static \1 \2", src, flags=re.M)


def _port_doc(fn_macro: str, direction: str, idx: int, port: Port) -> list[str]:
    base = _macro(fn_macro, direction, port.name)
    shape = f"{port.rows}x{port.cols}" if port.cols > 1 else f"{port.rows}"
    lines = [
        f"/* {direction.lower()}[{idx}] {port.name} ({shape}) [{port.unit}]: {port.description} */",
        f"#define {base} {idx}",
        f"#define {base}_SIZE {port.size}",
    ]
    off, used = 0, set()
    for i, pc in enumerate(port.pieces):
        pm = _macro(base, pc.name)
        if pm in used:  # names differing only in case (plan_t, plan_T): keep the macros distinct
            pm = f"{pm}_{i}"
        used.add(pm)
        lines.append(f"#define {pm}_OFFSET {off}  /* {pc.size} x [{pc.unit}] {pc.description} */")
        lines.append(f"#define {pm}_SIZE {pc.size}")
        off += pc.size
    return lines


def work_sizes(src: str, name: str) -> dict[str, int]:
    """Work-array sizes declared by the generated ``<name>_work`` function in ``src`` (``{}`` if absent)."""
    m = re.search(rf"int {re.escape(name)}_work\([^)]*\)\s*\{{(.*?)\}}", src, re.S)
    if not m:
        return {}
    return {key: int(v) for key, v in re.findall(r"if \((sz_\w+)\) \*\1 = (\d+);", m.group(1))}


def _unit_doc(unit: CodeUnit, src: str) -> list[str]:
    fn = unit.fn
    m = _macro(unit.name)
    sig = (
        ", ".join(f"{p.name}[{p.size}]" for p in unit.inputs)
        + " -> "
        + ", ".join(f"{p.name}[{p.size}]" for p in unit.outputs)
    )
    lines = ["", f"/* ---- {unit.name}({sig})", f" * {unit.doc}.", " */"]
    gen = work_sizes(src, unit.name)
    sizes = {"sz_arg": fn.sz_arg(), "sz_res": fn.sz_res(), "sz_iw": fn.sz_iw(), "sz_w": fn.sz_w()}
    # the larger of CasADi's two answers (the Function's and the generated code's), so static arrays suffice
    lines += [f"#define {m}_{key.upper()} {max(v, gen.get(key, 0))}" for key, v in sizes.items()]
    for i, p in enumerate(unit.inputs):
        lines += _port_doc(unit.name, "IN", i, p)
    for i, p in enumerate(unit.outputs):
        lines += _port_doc(unit.name, "OUT", i, p)
    return lines


def header_text(codes: list[ControllerCode], sources: dict[str, str] | None = None) -> str:
    """``maglev_controller.h``: includes, work sizes, port indices, layouts with units, constants.

    ``sources`` (file name -> generated C) lets the work sizes also cover what the generated code declares.
    """
    kinds = ", ".join(c.kind for c in codes)
    lines = [
        "/* maglev_controller.h -- generated by `maglev codegen` (maglev-ocp). Do not edit.",
        " *",
        f" * One control step of each controller ({kinds}) as self-contained C generated by",
        f" * CasADi {ca.__version__}'s code generator from the very CasADi Functions the Python",
        " * backend evaluates. Plain C99 + libm, no allocation in a step.",
        " *",
        " * Calling convention of every function f below (CasADi):",
        " *   int f(const casadi_real **arg, casadi_real **res, casadi_int *iw, casadi_real *w, int mem);",
        " * arg[i] points to input i, res[i] to output i: dense, column-major, casadi_real (double);",
        " * iw and w are caller-provided work arrays of at least F_SZ_IW and F_SZ_W entries, arg and",
        " * res arrays of at least F_SZ_ARG and F_SZ_RES pointers (the first n_in / n_out used for the",
        " * ports, the rest is scratch). mem = f_checkout() once at start-up (no allocation for these",
        " * functions), f_release(mem) at the end. Returns 0 on success.",
        " *",
        " * Units are SI: m, m/s, m/s^2, A, s. The sample period is MAGLEV_TS.",
        " * A controller keeps its memory in a state vector: call <kind>_init once with the first",
        " * reading, then <kind>_step once per period, copying state_out into state_in.",
        " */",
        "#ifndef MAGLEV_CONTROLLER_H",
        "#define MAGLEV_CONTROLLER_H",
        "",
    ]
    for c in codes:
        for u in c.units:
            lines.append(f'#include "{u.name}.h"')
    lines += ["", f"#define MAGLEV_TS {_c_number(k.Ts)}  /* control period [s] */"]
    for c in codes:
        lines += ["", "/* " + "=" * 70, f" * {c.kind}: {c.notes}", " */", f"#define MAGLEV_HAVE_{_macro(c.kind)} 1"]
        for name, v in c.defines.items():
            lines.append(f"#define {_macro(c.kind, name)} {v}")
        for name, (arr, comment) in c.constants.items():
            vals = ", ".join(_c_number(v) for v in np.ravel(arr))
            lines.append(f"/* {comment} */")
            lines.append(f"static const casadi_real {_macro(c.kind, name)}[{np.size(arr)}] = {{{vals}}};")
        for u in c.units:
            lines += _unit_doc(u, (sources or {}).get(f"{u.name}.c", ""))
    lines += ["", "#endif /* MAGLEV_CONTROLLER_H */", ""]
    return "\n".join(lines)


def main_text(codes: list[ControllerCode]) -> str:
    """The harness ``main.c`` for the controllers in ``codes``."""
    blocks = {"nmpc": tpl.NMPC_C, "fl": tpl.FL_C, "pid": tpl.PID_C, "observer": tpl.OBSERVER_C}
    kinds = [c.kind for c in codes]
    code = "".join(blocks[kd] for kd in kinds)
    dispatch = "".join(
        f'    if (!strcmp(kind, "{kd}")) {{ known = 1; rc = run_{kd}(&t, &rf, out, repeat); }}\n' for kd in kinds
    )
    return (
        tpl.MAIN_C.replace("@KINDS@", " | ".join(kinds))
        .replace("@CONTROLLER_CODE@", code)
        .replace("@DISPATCH@", dispatch.rstrip("\n"))
    )


@dataclass
class GeneratedSources:
    """The generated folder's files, in memory.

    Attributes
    ----------
    files : dict of str to str
        File name -> text.
    codes : list of ControllerCode
        What was generated.
    cflags : str
        Default ``CFLAGS`` written into the Makefile.
    seconds : float
        Wall time of the generation (building the Functions excluded if cached).
    """

    files: dict[str, str]
    codes: list[ControllerCode]
    cflags: str
    seconds: float = 0.0
    functions: list[str] = field(default_factory=list)

    @property
    def digest(self) -> str:
        """SHA-256 over every file (name and content): the build cache key."""
        h = hashlib.sha256()
        for name in sorted(self.files):
            h.update(name.encode() + b"\0" + self.files[name].encode() + b"\0")
        return h.hexdigest()

    def save(self, out_dir: str | os.PathLike) -> Path:
        """Write every file into ``out_dir`` (each atomically); returns the folder."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        umask = os.umask(0)
        os.umask(umask)
        for name, text in self.files.items():
            atomic_write_text(out / name, text)
            os.chmod(out / name, 0o666 & ~umask)  # sources readable like any checkout (temp files are 0600)
        return out

    def table(self) -> str:
        """One line per file: name and size."""
        lines = [f"{'file':<28} {'kB':>8}", "-" * 37]
        for name in sorted(self.files):
            lines.append(f"{name:<28} {len(self.files[name].encode()) / 1024:8.1f}")
        lines.append(f"{len(self.files)} files, generated in {self.seconds:.1f} s")
        return "\n".join(lines)


def generate_sources(codes: list[ControllerCode], cflags: str = tpl.DEFAULT_CFLAGS) -> GeneratedSources:
    """Generate every file of the folder for ``codes`` (nothing is written; see :meth:`GeneratedSources.save`).

    Parameters
    ----------
    codes : list of ControllerCode
        Controllers to generate (kinds must be distinct).
    cflags : str
        Default ``CFLAGS`` of the Makefile (overridable at ``make`` time).
    """
    t0 = time.perf_counter()
    kinds = [c.kind for c in codes]
    if len(set(kinds)) != len(kinds):
        raise ValueError(f"controller kinds must be distinct, got {kinds}")
    files: dict[str, str] = {}
    srcs, hdrs, fnames = [], [], []
    for c in codes:
        for u in c.units:
            src, hdr = generate_function_source(u.fn)
            if "malloc" in src:  # the step must not allocate (CasADi only does for memory objects)
                raise RuntimeError(f"generated {u.name}.c calls malloc")
            files[f"{u.name}.c"], files[f"{u.name}.h"] = src, hdr
            srcs.append(f"{u.name}.c")
            hdrs.append(f"{u.name}.h")
            fnames.append(u.name)
    files["maglev_controller.h"] = header_text(codes, files)
    files["main.c"] = main_text(codes)
    # largest sources first, so `make -j` starts the long compilations early
    srcs.sort(key=lambda s: -len(files[s]))
    files["Makefile"] = (
        tpl.MAKEFILE.replace("@CFLAGS@", cflags)
        .replace("@GEN_SRCS@", " ".join(srcs))
        .replace("@GEN_HDRS@", " ".join(hdrs))
    )
    files["CMakeLists.txt"] = tpl.CMAKELISTS.replace("@CFLAGS@", cflags).replace("@GEN_SRCS@", " ".join(srcs))
    files["README.md"] = (
        tpl.README.replace("@CASADI@", ca.__version__).replace("@KINDS@", ", ".join(kinds)).replace("@CFLAGS@", cflags)
    )
    manifest = {
        "format": "maglev-codegen/1",
        "casadi": ca.__version__,
        "Ts": k.Ts,
        "cflags": cflags,
        "controllers": {
            c.kind: {
                "functions": [u.name for u in c.units],
                "settings": c.settings,
                "constants": {n: np.ravel(a).tolist() for n, (a, _) in c.constants.items()},
                "defines": c.defines,
            }
            for c in codes
        },
        "sources": {s: hashlib.sha256(files[s].encode()).hexdigest() for s in sorted(srcs)},
    }
    files["manifest.json"] = json.dumps(manifest, indent=2, sort_keys=True) + "\n"
    return GeneratedSources(files, list(codes), cflags, time.perf_counter() - t0, fnames)


__all__ = [
    "CODEGEN_OPTIONS",
    "GeneratedSources",
    "generate_function_source",
    "generate_sources",
    "header_text",
    "main_text",
    "work_sizes",
]
