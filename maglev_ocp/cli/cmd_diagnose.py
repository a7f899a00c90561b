"""``maglev diagnose``: where the model and the rig part, which effect causes it, how far it shrinks."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from ..errors import UserError
from . import check_range

DESCRIPTION = """\
Diagnose the sim-to-real gap of a rig-log dataset (maglev-rig-log/1, closed- or
open-loop, any controller, locked axes allowed):

  baseline      the nominal model with its cogging law (seed eq. 9), C1..C4, xi0 and ell
                calibrated on the training runs with a prior at nominal (or --params as
                given); whole runs are held out for scoring
  residuals     filtered equation error: the same zero-phase FIR on the measured
                accelerations and on the model's (every current-carrying regressor),
                noise floor from the data (held-out runs, circular-shift null)
  localization  residual binned over gap x position, velocities, currents, current
                rates; Welch spectrum; least-squares period scan in d; regions
  attribution   every library effect fitted as a CasADi NLP on the shared model, scored
                on the held-out runs (reduction, significance, information criterion
                with the effective sample size); confusable sets reported together
  verdict       none | <effect> | a|b (confusable) | a+b (two effects) | unexplained

Writes DIR/report.json, DIR/report.md and figures.

Other modes:
  --selftest N --seed S   blind self-check on N generated datasets (confusion matrix,
                          localization accuracy, reduction vs the ideal one); with
                          --plant independent on the independent rig (maglev_ocp.rigsim:
                          none, 1-3 effects with laws other than the library's, effects
                          outside the library)
  --generate DIR          write a diagnosis dataset from the plant (--effect, --seed);
                          --plant independent: from the independent rig (truth.json beside)
  --scenario FILE --effect NAME
                          closed-loop view: the scenario on the model, on the rig with
                          the effect, and with the controller's model carrying the
                          fitted effect (settling time, steady error)
  --closed-loop FILE --from REPORT
                          how far the gap shrinks in closed loop, from the report
                          itself: the scenario on its plant (the rig log) against
                          simulations of the report's baseline.yaml and model.yaml
                          (its verdict's fitted laws)
"""


#: Files of a diagnosis report folder (an existing --out must hold one to be replaced).
REPORT_FILES: tuple[str, ...] = ("report.json", "report.md")


def register(sub) -> None:
    """Add the ``diagnose`` subcommand."""
    from . import add_command

    p = add_command(
        sub,
        "diagnose",
        help="find, attribute and quantify the gap between model and data",
        description=DESCRIPTION,
        example="maglev diagnose data/rig --out results/diagnosis   |   maglev diagnose --selftest 30 --seed 1",
    )
    p.add_argument("dataset", nargs="?", help="rig-log dataset folder (with dataset.yaml)")
    p.add_argument("--out", metavar="DIR", help="output folder (report.json, report.md, figures)")
    p.add_argument("--params", metavar="FILE", help="parameter YAML: test this model as given (no calibration)")
    p.add_argument("--candidates", nargs="+", metavar="EFFECT", help="restrict the candidate library")
    p.add_argument("--seed", type=int, default=0, help="seed of the null draws / self-check / generation (default 0)")
    p.add_argument("--fc", type=float, default=15.0, metavar="HZ", help="residual filter cut-off (default 15 Hz)")
    p.add_argument("--no-figures", action="store_true", help="write report.json and report.md only")
    p.add_argument("--selftest", type=int, metavar="N", help="run the blind self-check on N generated datasets")
    p.add_argument(
        "--baseline",
        choices=("given", "calibrated"),
        default="calibrated",
        help="self-check: let the diagnosis calibrate the constants, or hand it the nominal model (default calibrated)",
    )
    p.add_argument("--runs", type=int, default=6, metavar="N", help="generated datasets: runs (default 6)")
    p.add_argument(
        "--duration", type=float, default=10.0, metavar="S", help="generated datasets: seconds per run (default 10)"
    )
    p.add_argument(
        "--loop",
        choices=("auto", "compiled", "python"),
        default="auto",
        help="generated datasets: closed loop of the runs: compiled (one C call per run, equal to the Python loop), "
        "python, or auto (compiled where a C compiler is found, default)",
    )
    p.add_argument("--keep-reports", action="store_true", help="self-check: write every dataset's report")
    p.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="self-check: local worker processes (Dask) the datasets are spread over; 1 runs in-process; the "
        "result does not depend on it (default: CPU count)",
    )
    p.add_argument(
        "--truths",
        nargs="+",
        metavar="NAME",
        help="self-check: draw only these truths (library effects and/or none; default all)",
    )
    p.add_argument("--generate", metavar="DIR", help="write a diagnosis dataset from the plant into DIR")
    p.add_argument(
        "--plant",
        choices=("library", "independent"),
        default="library",
        help="--generate / --selftest: the suite's plant with the library's effects (default), or the independent "
        "rig simulator maglev_ocp.rigsim with its own law families and effects outside the library",
    )
    p.add_argument(
        "--effect",
        metavar="NAME",
        help="effect for --generate / --scenario (library plant: one library effect or none; independent plant: "
        "comma-separated rigsim effects, e.g. cogging,friction, or none)",
    )
    p.add_argument(
        "--effect-param",
        nargs="+",
        default=[],
        metavar="KEY=VALUE",
        help="effect parameters in the plant (e.g. xi0=5 ell=0.004; independent plant: EFFECT.KEY=VALUE, "
        "EFFECT.family=NAME, or KEY=VALUE with one effect)",
    )
    p.add_argument(
        "--extra",
        choices=("vibration", "guide_ripple"),
        help="--generate: add an effect outside the library (7.3 Hz vibration, 8.6 mm guide ripple)",
    )
    p.add_argument("--scenario", metavar="FILE", help="closed-loop view on this scenario (needs --effect)")
    p.add_argument(
        "--fitted-from",
        metavar="REPORT",
        help="closed-loop view: take the fitted effect from this report.json (default: fit it)",
    )
    p.add_argument(
        "--closed-loop",
        metavar="SCENARIO",
        help="run SCENARIO on its plant and on the models of --from REPORT; compare (writes --out DIR)",
    )
    p.add_argument("--from", dest="from_report", metavar="REPORT", help="--closed-loop: the diagnosis report.json")
    p.set_defaults(handler=run)


def _effect_number(key: str, text: str) -> float:
    """The finite number of ``--effect-param KEY=TEXT`` (one-line UserError naming the key otherwise)."""
    try:
        x = float(text)
    except ValueError:
        raise UserError(f"--effect-param: {key}: not a number: {text!r}") from None
    if not math.isfinite(x):
        raise UserError(f"--effect-param: {key}: must be finite")
    return x


def _kv(items: list[str]) -> dict[str, float]:
    out = {}
    for it in items:
        if "=" not in it:
            raise UserError(f"--effect-param: expected KEY=VALUE, got {it!r}")
        key, val = it.split("=", 1)
        out[key.strip()] = _effect_number(key, val)
    return out


def independent_effects(names: str | None, items: list[str]) -> dict[str, dict]:
    """``{effect: {"family": ..., param: value}}`` for the independent rig from ``--effect`` / ``--effect-param``.

    Effects, families and parameters are checked against the catalogue of
    :mod:`maglev_ocp.rigsim.laws`; anything else is a :class:`UserError` naming what is allowed.
    """
    from ..rigsim.laws import LAWS

    chosen = [n.strip() for n in (names or "").split(",") if n.strip()]
    if chosen == ["none"]:
        chosen = []
    bad = [n for n in chosen if n not in LAWS]
    if bad:
        raise UserError(
            f"--effect: unknown effect(s) {bad} of the independent rig; choose from {', '.join(LAWS)}, none"
        )
    if len(set(chosen)) != len(chosen):
        raise UserError(f"--effect: each effect at most once, got {chosen}")
    spec: dict[str, dict] = {n: {} for n in chosen}
    for it in items:
        if "=" not in it:
            raise UserError(f"--effect-param: expected [EFFECT.]KEY=VALUE, got {it!r}")
        key, val = (x.strip() for x in it.split("=", 1))
        eff, _, name = key.rpartition(".")
        if not eff:
            if len(chosen) != 1:
                raise UserError(f"--effect-param: {key}: name the effect (EFFECT.{key}=...) when there is not one")
            eff = chosen[0]
        if eff not in spec:
            raise UserError(f"--effect-param: {key}: {eff!r} is not among the effects given ({', '.join(chosen)})")
        spec[eff][name] = val
    return {n: _independent_law(n, kv) for n, kv in spec.items()}


def _independent_law(n: str, kv: dict[str, str]) -> dict:
    """One effect of the independent rig: family and numeric parameters checked against its catalogue."""
    from ..rigsim.laws import LAWS

    law = LAWS[n]
    fam = kv.pop("family", law.families[0])
    if fam not in law.families:
        raise UserError(
            f"--effect-param: {n}.family: {fam!r} is not a law of {n}; choose from {', '.join(law.families)}"
        )
    allowed = law.DEFAULTS[fam]
    params: dict[str, float] = {}
    for q, v in kv.items():
        if q not in allowed:
            raise UserError(f"--effect-param: {n} ({fam}) has no parameter {q!r}; known: {', '.join(sorted(allowed))}")
        params[q] = _effect_number(f"{n}.{q}", v)
    try:
        law(fam, **params)
    except ValueError as e:
        raise UserError(f"--effect-param: {n}: {e}") from None
    return {"family": fam, **params}


def _check_effect(name: str | None, allow_none: bool = False) -> None:
    from ..effects import EFFECTS

    if name is None:
        return
    if allow_none and name == "none":
        return
    if name not in EFFECTS:
        raise UserError(
            f"--effect: unknown effect {name!r}; choose from {', '.join(EFFECTS)}" + (", none" if allow_none else "")
        )


def _settings(args, **kw):
    from ..diagnosis.diagnose import LIBRARY, DiagnoseSettings

    check_range("--fc", args.fc, 0.5, 200.0, "Hz", lo_open=True)
    if args.candidates:
        bad = [c for c in args.candidates if c not in LIBRARY]
        if bad:
            raise UserError(f"--candidates: unknown {bad}; choose from {', '.join(LIBRARY)}")
    return DiagnoseSettings(fc_hz=args.fc, candidates=args.candidates, seed=args.seed, **kw)


def _generator(args):
    from ..diagnosis.generate import GeneratorSettings

    if not 2 <= args.runs <= 100:
        raise UserError(f"--runs: {args.runs} is outside 2..100")
    check_range("--duration", args.duration, 2.0, 600.0, "s")
    return GeneratorSettings(n_runs=args.runs, run_duration=args.duration, loop=getattr(args, "loop", "auto"))


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev diagnose``."""
    if args.seed < 0:
        raise UserError(f"--seed: must be >= 0, got {args.seed}")
    modes = [m for m in ("dataset", "selftest", "generate", "scenario", "closed_loop") if getattr(args, m) is not None]
    if len(modes) != 1:
        raise UserError(
            "give exactly one of DATASET, --selftest N, --generate DIR, --scenario FILE, --closed-loop SCENARIO"
        )
    mode = modes[0]
    if mode == "closed_loop":
        return _closed_loop(args)
    if mode == "selftest":
        return _selftest(args)
    if mode == "generate":
        return _generate(args)
    if mode == "scenario":
        return _scenario(args)
    return _dataset(args)


def _dataset(args) -> int:
    from ..diagnosis import diagnose
    from ..diagnosis.report import write_report
    from ..output import check_output_dir, replace_dir
    from ..riglog import read_dataset
    from . import load_model_params

    if not args.out:
        raise UserError("--out DIR is required")
    check_output_dir(args.out, expect=REPORT_FILES)
    folder = Path(args.dataset)
    if not (folder / "dataset.yaml").is_file():
        raise UserError(f"{folder}: not a dataset folder (no dataset.yaml)")
    params = load_model_params(args.params) if args.params else None
    st = _settings(args)
    ds = read_dataset(folder)
    d = diagnose(ds, params=params, settings=st, progress=True)
    print(d.table())
    with replace_dir(args.out) as tmp:
        write_report(d, tmp, figures=not args.no_figures)
    print(f"report: {Path(args.out) / 'report.md'}")
    return 0


def _selftest(args) -> int:
    from ..diagnosis.selftest import DRAWS, SelftestSettings, run_selftest

    if args.selftest < 1:
        raise UserError(f"--selftest: N must be >= 1, got {args.selftest}")
    if args.workers is not None and args.workers < 1:
        raise UserError(f"--workers: must be >= 1, got {args.workers}")
    if args.plant == "independent":
        return _selftest_independent(args)
    if args.truths:
        bad = [t for t in args.truths if t not in DRAWS]
        if bad:
            raise UserError(f"--truths: unknown {bad}; choose from {', '.join(DRAWS)}")
        if args.baseline == "calibrated" and set(args.truths) == {"parameter_error"}:
            raise UserError("--truths: parameter_error is absorbed by a calibrated baseline; use --baseline given")
    st = SelftestSettings(
        n=args.selftest,
        seed=args.seed,
        baseline=args.baseline,
        generator=_generator(args),
        diagnose=_settings(args, simulate=False),
        truths=args.truths,
    )
    return _run_and_write(run_selftest, st, args)


def _run_and_write(run_fn, st, args) -> int:
    """Run a self-check (``run_fn``: library or independent rig) and print its table; ``--out`` is replaced whole."""
    from ..output import check_output_dir, replace_dir

    workers = args.workers or os.cpu_count() or 1
    if args.out:
        check_output_dir(args.out, expect=("selftest.json", "selftest.md"))
        with replace_dir(args.out) as tmp:
            res = run_fn(st, progress=True, out_dir=tmp, keep_reports=args.keep_reports, workers=workers)
    else:
        res = run_fn(st, progress=True, out_dir=None, keep_reports=args.keep_reports, workers=workers)
    print(res.table())
    if args.out:
        print(f"written: {Path(args.out) / 'selftest.md'}")
    return 0


def _selftest_independent(args) -> int:
    """``--selftest N --plant independent``: the blind self-check on datasets of the independent rig."""
    from ..diagnosis.selftest import SelftestSettings
    from ..diagnosis.selftest_rig import run_rig_selftest

    if args.truths:
        raise UserError("--truths: the independent rig draws its own scenarios (none, 1-3 effects, out of library)")
    if args.baseline != "calibrated":
        raise UserError("--baseline given: the independent rig's constants are off nominal; only 'calibrated' applies")
    st = SelftestSettings(
        n=args.selftest, seed=args.seed, generator=_generator(args), diagnose=_settings(args, simulate=False)
    )
    return _run_and_write(run_rig_selftest, st, args)


def _generate(args) -> int:
    import numpy as np

    from ..diagnosis.generate import generate_dataset
    from ..diagnosis.selftest import selftest_plant
    from ..output import check_output_dir, replace_dir
    from ..params import NOMINAL
    from ..riglog import read_dataset

    if args.plant == "independent":
        return _generate_independent(args)
    _check_effect(args.effect, allow_none=True)
    check_output_dir(args.generate, "--generate", expect=("dataset.yaml",))
    eff = _kv(args.effect_param)
    # The plant has the shared model's cogging (seed eq. (9), MODEL.md) at nominal, as a rig does; an effect adds
    # to it (``cogging``: slot harmonics and another decay beyond eq. (9)).
    params = NOMINAL
    effects: dict = {}
    if args.effect and args.effect != "none":
        from ..effects import EFFECTS

        bad = set(eff) - set(EFFECTS[args.effect].param_names())
        if bad:
            raise UserError(
                f"--effect-param: {args.effect} has no parameters {sorted(bad)}; "
                f"known: {', '.join(EFFECTS[args.effect].param_names())}"
            )
        effects = {args.effect: {"enabled": True, **eff}}
    cfg = selftest_plant("given", effects)
    force, info = None, None
    if args.extra:
        from ..diagnosis.generate import OUT_OF_LIBRARY

        force, info = OUT_OF_LIBRARY[args.extra][0](), {"name": args.extra}
    gen = generate_dataset(
        cfg,
        params,
        seed=np.random.SeedSequence(args.seed),
        settings=_generator(args),
        extra_force=force,
        extra_info=info,
        progress=True,
    )
    with replace_dir(args.generate) as tmp:  # a generated dataset carries its truth: replaced whole, not appended
        gen.save(tmp)
    print(read_dataset(args.generate).table())
    print(f"written: {args.generate}")
    return 0


def _generate_independent(args) -> int:
    """``--generate DIR --plant independent``: a dataset (and its truth.json) from the independent rig."""
    import json

    from ..output import check_output_dir, replace_dir
    from ..riglog import read_dataset
    from ..rigsim import RigSettings, generate

    if args.extra:
        raise UserError("--extra: the independent rig names its effects outside the library in --effect "
                        "(resonance, encoder_error, temperature_drift, cable)")  # fmt: skip
    effects = independent_effects(args.effect, args.effect_param)
    _generator(args)  # the same checks of --runs and --duration
    check_output_dir(args.generate, "--generate", expect=("dataset.yaml",))
    with replace_dir(args.generate) as tmp:
        generate(tmp, effects, args.seed, RigSettings(n_runs=args.runs, duration=args.duration))
    truth = json.loads((Path(args.generate) / "truth.json").read_text())
    print(read_dataset(args.generate).table())
    print(f"written: {args.generate} (independent rig; expected verdict: {truth['expected_verdict']})")
    return 0


def _scenario(args) -> int:
    from ..diagnosis.closed_loop import closed_loop_view, fitted_from_report
    from ..diagnosis.generate import GeneratorSettings
    from ..output import check_output_dir, replace_dir

    if not args.effect:
        raise UserError("--scenario needs --effect NAME")
    _check_effect(args.effect)
    if not Path(args.scenario).is_file():
        raise UserError(f"{args.scenario}: no such scenario file")
    if args.out:
        check_output_dir(args.out, expect=("closed_loop.json", "closed_loop.md"))
    fitted = fitted_from_report(args.fitted_from, args.effect) if args.fitted_from else None
    view = closed_loop_view(
        args.scenario,
        args.effect,
        _kv(args.effect_param),
        fitted,
        progress=True,
        fit_settings=GeneratorSettings(n_runs=max(args.runs, 3), run_duration=args.duration),
    )
    print(view.table())
    if args.out:
        with replace_dir(args.out) as tmp:
            view.save(tmp)
        print(f"written: {Path(args.out) / 'closed_loop.md'}")
    return 0


def _closed_loop(args) -> int:
    from ..diagnosis.closed_loop import closed_loop_from_report

    if not args.from_report:
        raise UserError("--closed-loop needs --from REPORT (a diagnosis report.json)")
    if not Path(args.closed_loop).is_file():
        raise UserError(f"{args.closed_loop}: no such scenario file")
    if not Path(args.from_report).is_file():
        raise UserError(f"{args.from_report}: no such report")
    res = closed_loop_from_report(args.closed_loop, args.from_report, progress=True)
    print(res.table())
    if args.out:
        res.save(args.out)
        print(f"written: {Path(args.out) / 'closed_loop.md'}")
    return 0
