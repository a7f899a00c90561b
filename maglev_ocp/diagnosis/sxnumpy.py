"""A CasADi SX Function evaluated over many points at once with numpy.

The diagnosis evaluates the same small SX Function (the shared model with a
candidate effect inlined, and its Jacobian with respect to the effect's
parameters) at every sample of a dataset, tens of thousands of points per
call and hundreds of calls per diagnosis. CasADi's ``map`` runs the
Function's instruction list once per point in its virtual machine; here the
instruction list is translated once into a Python function whose every
instruction is one numpy operation on the whole vector of points (the same
IEEE operations in the same order, so the values agree with CasADi's to
rounding of the elementary functions). No compiler is needed.

:func:`vectorized` returns the translated evaluator of a Function, or None
when the Function uses an operation this translation does not know (the
caller then keeps CasADi's ``map``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import casadi as ca
import numpy as np
import scipy.special as sps

# Unary and binary operations: CasADi op code -> Python expression with a (and b).
_UNARY: dict[int, str] = {
    ca.OP_ASSIGN: "{a}",
    ca.OP_NEG: "-{a}",
    ca.OP_EXP: "_np.exp({a})",
    ca.OP_LOG: "_np.log({a})",
    ca.OP_SQRT: "_np.sqrt({a})",
    ca.OP_SQ: "{a}*{a}",
    ca.OP_TWICE: "2.0*{a}",
    ca.OP_SIN: "_np.sin({a})",
    ca.OP_COS: "_np.cos({a})",
    ca.OP_TAN: "_np.tan({a})",
    ca.OP_ASIN: "_np.arcsin({a})",
    ca.OP_ACOS: "_np.arccos({a})",
    ca.OP_ATAN: "_np.arctan({a})",
    ca.OP_NOT: "_np.logical_not({a})*1.0",
    ca.OP_FLOOR: "_np.floor({a})",
    ca.OP_CEIL: "_np.ceil({a})",
    ca.OP_FABS: "_np.abs({a})",
    ca.OP_SIGN: "_np.sign({a})",
    ca.OP_ERF: "_sps.erf({a})",
    ca.OP_INV: "1.0/{a}",
    ca.OP_SINH: "_np.sinh({a})",
    ca.OP_COSH: "_np.cosh({a})",
    ca.OP_TANH: "_np.tanh({a})",
    ca.OP_ASINH: "_np.arcsinh({a})",
    ca.OP_ACOSH: "_np.arccosh({a})",
    ca.OP_ATANH: "_np.arctanh({a})",
    ca.OP_LOG1P: "_np.log1p({a})",
    ca.OP_EXPM1: "_np.expm1({a})",
}
_BINARY: dict[int, str] = {
    ca.OP_ADD: "{a}+{b}",
    ca.OP_SUB: "{a}-{b}",
    ca.OP_MUL: "{a}*{b}",
    ca.OP_DIV: "{a}/{b}",
    ca.OP_POW: "_np.power({a},{b})",
    ca.OP_CONSTPOW: "_np.power({a},{b})",
    ca.OP_LT: "({a}<{b})*1.0",
    ca.OP_LE: "({a}<={b})*1.0",
    ca.OP_EQ: "({a}=={b})*1.0",
    ca.OP_NE: "({a}!={b})*1.0",
    ca.OP_AND: "_np.logical_and({a},{b})*1.0",
    ca.OP_OR: "_np.logical_or({a},{b})*1.0",
    ca.OP_FMOD: "_np.fmod({a},{b})",
    ca.OP_COPYSIGN: "_np.copysign({a},{b})",
    ca.OP_IF_ELSE_ZERO: "_np.where({a}!=0,{b},0.0)",
    ca.OP_FMIN: "_np.minimum({a},{b})",
    ca.OP_FMAX: "_np.maximum({a},{b})",
    ca.OP_ATAN2: "_np.arctan2({a},{b})",
    ca.OP_HYPOT: "_np.hypot({a},{b})",
}


def _source(f: ca.Function) -> str | None:
    """Python source of ``_f(*inputs) -> [nonzeros of each output]`` (None: an unknown operation)."""
    lines = ["def _f(*_in):"]
    outs: list[list[str]] = [["0.0"] * f.nnz_out(i) for i in range(f.n_out())]
    for k in range(f.n_instructions()):
        op = f.instruction_id(k)
        o = f.instruction_output(k)
        i = f.instruction_input(k)
        if op == ca.OP_INPUT:
            lines.append(f"    w{o[0]} = _in[{i[0]}][{i[1]}]")
        elif op == ca.OP_OUTPUT:
            # an output reads a work variable that a later instruction may overwrite: copy it now
            lines.append(f"    o{o[0]}_{o[1]} = w{i[0]}")
            outs[o[0]][o[1]] = f"o{o[0]}_{o[1]}"
        elif op == ca.OP_CONST:
            lines.append(f"    w{o[0]} = {float(f.instruction_constant(k))!r}")
        elif op in _UNARY:
            lines.append(f"    w{o[0]} = " + _UNARY[op].format(a=f"w{i[0]}"))
        elif op in _BINARY:
            lines.append(f"    w{o[0]} = " + _BINARY[op].format(a=f"w{i[0]}", b=f"w{i[1]}"))
        else:
            return None
    lines.append("    return [" + ", ".join("[" + ", ".join(o) + "]" for o in outs) + "]")
    return "\n".join(lines)


@functools.lru_cache(maxsize=256)
def _compiled(f: ca.Function) -> Callable | None:
    src = _source(f)
    if src is None:
        return None
    ns: dict = {"_np": np, "_sps": sps}
    exec(compile(src, f"<sxnumpy {f.name()}>", "exec"), ns)  # the source is generated from the Function
    return ns["_f"]


@functools.lru_cache(maxsize=256)
def vectorized(f: ca.Function) -> Callable[..., list[np.ndarray]] | None:
    """Evaluator of the SX Function ``f`` at many points: ``ev(*inputs) -> [outputs]``.

    Each input is a dense array of shape ``(nnz_in,)`` (the same at every
    point) or ``(nnz_in, N)`` (one column per point); each output is returned
    dense, of shape ``(rows, cols, N)``. None if ``f`` uses an operation the
    translation does not cover.

    Parameters
    ----------
    f : casadi.Function
        An SX Function with dense inputs (the evaluator is kept per Function: the fits call it at every
        iteration).
    """
    if not f.is_a("SXFunction"):
        return None
    raw = _compiled(f)
    if raw is None:
        return None
    sp_out = [f.sparsity_out(i) for i in range(f.n_out())]
    rc = [(np.array(sp.row()), np.array(sp.get_col())) for sp in sp_out]

    def ev(*inputs: np.ndarray) -> list[np.ndarray]:
        N = max((np.shape(x)[1] for x in inputs if np.ndim(x) == 2), default=1)
        with np.errstate(all="ignore"):
            vals = raw(*[np.asarray(x, float) for x in inputs])
        out = []
        for sp, (rows, cols), nz in zip(sp_out, rc, vals, strict=True):
            a = np.zeros((sp.size1(), sp.size2(), N))
            for r_, c_, v in zip(rows, cols, nz, strict=True):
                a[r_, c_] = v
            out.append(a)
        return out

    return ev


__all__ = ["vectorized"]
