"""Why an amplifier lag and a Stribeck friction explain the same misfit, measured on one dataset (issue 27).

In closed loop the current rate follows the velocity: at one frequency ``w`` a lag's force error
``-t_eff dF/dt`` is ``t_eff M w^2 v``, a (negative) damping that a friction law's viscous and Stribeck terms can
take up. This script measures, on a dataset's split and calibrated baseline as the diagnosis makes them:

1. the held-out correlation of each current rate with the velocities;
2. the joint model ``saturation (law) + friction (stribeck)`` without the lag, with each lag member searched,
   and with the library's lag *held* at given effective delays (e.g. the truth) with everything else refitted:
   training SSE, held-out mean square, paired z against the model without the lag, the friction it leaves;
3. the separating test: the share of the held-out residual (of the model without the lag) along the current
   rates *at a fixed state*, beyond a flexible static map of the velocities, state and currents
   (:func:`maglev_ocp.diagnosis.signatures.static_basis`), against its circular-shift null (99 % quantile).

Usage::

    python -m benchmarks.lag_vs_friction DATASET [--saturation field] [--hold 1.477e-3 ...] [--out FILE.md]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np

from maglev_ocp.diagnosis import signatures as sg
from maglev_ocp.diagnosis.attribution import paired_z, stack
from maglev_ocp.diagnosis.fit import fit_candidate, residuals_with
from maglev_ocp.diagnosis.library import combine, family_specs
from maglev_ocp.diagnosis.residuals import CHANNELS
from maglev_ocp.diagnosis.settings import DiagnoseSettings
from maglev_ocp.diagnosis.stages.baseline import calibrate_baseline
from maglev_ocp.diagnosis.stages.models import joint_spec
from maglev_ocp.diagnosis.stages.split import split_dataset
from maglev_ocp.output import atomic_write_text
from maglev_ocp.riglog import read_dataset


def _member(fam: dict, effect: str, law: str):
    return next(m for m in fam[effect] if m.law == law)


def main(argv: list[str] | None = None) -> str:
    """Run the measurements; print and return them as markdown."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dataset")
    ap.add_argument("--saturation", default="field", help="saturation member of the joint model")
    ap.add_argument("--hold", type=float, nargs="*", default=[], help="effective delays [s] to hold the lag at")
    ap.add_argument("--members", default="default,fractional,second", help="lag members to search")
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args(argv)
    ds = read_dataset(a.dataset)
    st = DiagnoseSettings()
    split = split_dataset(ds, st)
    base = calibrate_baseline(split, None, st, float(ds.encoder_resolution or 1e-5))
    fam = family_specs()
    others = [_member(fam, "saturation", a.saturation), _member(fam, "friction", "stribeck")]
    lines = [f"# Lag against friction on `{a.dataset}`", ""]

    def fit(specs, warm=None, hold=False):
        sp = specs[0]
        for s in specs[1:]:
            sp = combine(sp, s)
        sp = joint_spec(sp, base)
        fr = fit_candidate(sp, base.data_train, base.p, u_runs=split.u_train, warm=warm, hold_lag=hold)
        te = residuals_with(sp, fr, split.test, base.p, split.u_test)
        return sp, fr, te, stack(te, base.fvec)

    feat = {k: np.concatenate([r.feat[k] for r in split.test if r.n]) for k in split.test[0].feat}
    lines += ["| current rate | velocity | held-out correlation |", "|---|---|---|"]
    for r_, v_ in (("di_d", "g_dot"), ("di_q", "d_dot")):
        lines.append(f"| {r_} | {v_} | {np.corrcoef(feat[r_], feat[v_])[0, 1]:+.3f} |")
    t0 = time.perf_counter()
    ref = fit(others)
    rows = [("without the lag", ref)]
    for m in a.members.split(","):
        rows.append((f"lag '{m}' searched", fit([*others, _member(fam, "amplifier_lag", m)], ref[1].params())))
    lag = fam["amplifier_lag"][0]
    for t in a.hold:
        rows.append((f"lag held at {t * 1e6:.0f} us", fit([*others, lag], {"effective_delay_s": t}, hold=True)))
    lines += [
        "",
        "| model | training SSE | held-out mean square | paired z over 'without' | t_eff [us] | friction g: Coulomb, "
        "viscous, Stribeck | friction d: Coulomb, viscous, Stribeck |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, (_, fr, _, e) in rows:
        p = fr.params()
        fg = ", ".join(f"{p.get(f'friction.{k}_g', math.nan):.3f}" for k in ("coulomb", "viscous", "stribeck"))
        fd = ", ".join(f"{p.get(f'friction.{k}_d', math.nan):.3f}" for k in ("coulomb", "viscous", "stribeck"))
        z = paired_z(ref[3], e) if fr is not ref[1] else math.nan
        t_eff = fr.extra.get("effective_delay_s", math.nan) * 1e6
        lines.append(f"| {name} | {fr.sse:.2f} | {np.mean(e**2):.5f} | {z:.2f} | {t_eff:.0f} | {fg} | {fd} |")
    rng = np.random.default_rng(st.seed)
    lines += [
        "",
        "Separating test (held-out residual of the model without the lag): share along the current rates beyond a "
        "flexible static map",
        "",
        "| channel | share | null 99 % | rms [m/s^2] | shows |",
        "|---|---|---|---|---|",
    ]
    for c, ch in enumerate(CHANNELS):
        y, f, ids = sg._stack(ref[2], c)
        if len(y) < 50:
            continue
        cols = [sg.static_basis(f)] + [sg.SIGNATURES[o.name].matrix(f, ch) for o in others]
        a_ = sg._normalized(np.column_stack(cols))
        b_ = sg._normalized(sg.SIGNATURES["amplifier_lag"].matrix(f, ch))
        inc = sg._Increment(a_, b_)
        share = inc(y)
        q = float(np.quantile([inc(sg._shifted(y, ids, rng)) for _ in range(200)], 0.99))
        lines.append(f"| {ch} | {share:.4f} | {q:.4f} | {math.sqrt(share * np.mean(y**2)):.4g} | {share > q} |")
    lines += ["", f"({time.perf_counter() - t0:.0f} s)"]
    text = "\n".join(lines) + "\n"
    print(text)
    if a.out:
        atomic_write_text(a.out, text)
    return text


if __name__ == "__main__":
    main()
