"""``maglev diagnose``: where the model and the rig part, which effect causes it, how far it shrinks."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from ..errors import UserError
from . import check_range

DESCRIPTION = """\
Diagnose the sim-to-real gap of a rig-log dataset, check the diagnosis blind, generate
datasets for it, and see what a diagnosis changes in closed loop. One mode per subcommand:

  run DATASET --out DIR       the diagnosis (below); writes report.json, report.md, figures and
                              model.yaml (a model file: controller: {model: DIR/model.yaml}); a
                              confusable verdict (a|b) also writes experiment.yaml, the run plan
                              that separates them (maglev simulate --experiment DIR/experiment.yaml,
                              or a rig following DIR/experiment_references/*.csv)
  run DATA1 DATA2 --out DIR   the diagnosis on the datasets pooled (each keeps held-out runs)
  selftest N                  blind self-check on N generated datasets (confusion matrix,
                              localization accuracy, reduction vs the ideal one); --generator
                              independent: on the independent rig (maglev_ocp.rigsim)
  generate DIR                write a diagnosis dataset (--effect, --seed; --generator independent:
                              from the independent rig, truth.json beside)
  closed-loop SCENARIO        --from REPORT: the scenario on its plant against simulations of the
                              report's baseline.yaml and model.yaml; --effect NAME: the scenario on
                              the model, on the rig with the effect, and with the controller's
                              model carrying the fitted effect

The diagnosis (run):
  baseline      the nominal model with its cogging law (seed eq. 9), C1..C4, xi0 and ell
                calibrated on the training runs with a prior at nominal (or --given FILE as
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
"""

#: The modes of ``maglev diagnose`` (its subcommands).
MODES: tuple[str, ...] = ("run", "selftest", "generate", "closed-loop")

#: Files of a diagnosis report folder (an existing --out must hold one to be replaced).
REPORT_FILES: tuple[str, ...] = ("report.json", "report.md")


def register(sub) -> None:
    """Add ``diagnose`` with its subcommands ``run``, ``selftest``, ``generate`` and ``closed-loop``."""
    from . import add_command

    p = add_command(
        sub,
        "diagnose",
        help="find, attribute and quantify the gap between model and data (run | selftest | generate | closed-loop)",
        description=DESCRIPTION,
        example="maglev diagnose run data/rig --out results/diagnosis   |   maglev diagnose selftest 30 --seed 1",
    )
    p.set_defaults(handler=_no_mode)
    modes = p.add_subparsers(dest="mode", metavar="MODE")
    _register_run(modes)
    _register_selftest(modes)
    _register_generate(modes)
    _register_closed_loop(modes)


def _mode(modes, name: str, help: str, example: str):
    from . import _Formatter, add_quiet

    q = modes.add_parser(name, help=help, description=help, epilog=f"example:\n  {example}", formatter_class=_Formatter)
    add_quiet(q)
    return q


def _seed(q) -> None:
    q.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")


def _analysis_flags(q) -> None:
    """Flags of the diagnosis itself (run, selftest)."""
    q.add_argument(
        "--candidates", nargs="+", metavar="LIST", help="restrict the candidate library (comma-separated effects)"
    )
    q.add_argument("--fc", type=float, default=15.0, metavar="HZ", help="residual filter cut-off (default 15 Hz)")
    q.add_argument(
        "--exclude-law",
        action="append",
        default=None,
        metavar="EFFECT:MEMBER",
        help="leave a law-family member out of the candidate library (repeatable; e.g. 'end_effect:two ends')",
    )


def _generator_flags(q) -> None:
    """Flags of generated datasets (selftest, generate)."""
    q.add_argument(
        "--generator",
        dest="plant",
        choices=("library", "independent"),
        default="library",
        help="the suite's plant with the library's effects (default), or the independent rig simulator "
        "maglev_ocp.rigsim with its own law families and effects outside the library",
    )
    q.add_argument("--runs", type=int, default=6, metavar="N", help="runs per dataset, 2..100 (default 6)")
    q.add_argument("--duration", type=float, default=10.0, metavar="S", help="seconds per run, 2..600 (default 10)")
    q.add_argument(
        "--loop",
        choices=("auto", "compiled", "python"),
        default="auto",
        help="closed loop of the runs: compiled (one C call per run, equal to the Python loop), python, or auto "
        "(compiled where a C compiler is found, default)",
    )


def _effect_flags(q, what: str) -> None:
    q.add_argument("--effect", metavar="NAME", help=what)
    q.add_argument(
        "--effect-param",
        nargs="+",
        default=[],
        metavar="KEY=VALUE",
        help="effect parameters, comma- or space-separated (e.g. xi0=5,ell=0.004; independent generator: "
        "EFFECT.KEY=VALUE, EFFECT.family=NAME, or KEY=VALUE with one effect)",
    )


def _register_run(modes) -> None:
    q = _mode(modes, "run", "diagnose a rig-log dataset", "maglev diagnose run data/rig --out results/diagnosis")
    q.add_argument(
        "dataset",
        metavar="DATASET",
        nargs="+",
        help="rig-log dataset folder(s) (with dataset.yaml); several are pooled (e.g. the data and the run of a "
        "confusable verdict's experiment.yaml), each keeping held-out runs of its own",
    )
    q.add_argument("--out", required=True, metavar="DIR", help="report folder (report.json, report.md, model.yaml)")
    q.add_argument(
        "--given",
        metavar="FILE",
        help="parameter file of the baseline, tested as given (no calibration; default: calibrate it)",
    )
    _analysis_flags(q)
    _seed(q)
    q.add_argument("--no-figures", action="store_true", help="write report.json, report.md and model.yaml only")
    q.set_defaults(handler=lambda a: _dataset(_common(a)))


def _register_selftest(modes) -> None:
    q = _mode(
        modes, "selftest", "blind self-check of the diagnosis on N generated datasets", "maglev diagnose selftest 30"
    )
    q.add_argument("selftest", type=int, metavar="N", help="number of generated datasets (1..1000)")
    q.add_argument("--out", metavar="DIR", help="also write selftest.json / selftest.md here")
    q.add_argument(
        "--baseline",
        choices=("given", "calibrated"),
        default="calibrated",
        help="let the diagnosis calibrate the constants, or hand it the nominal model (default calibrated)",
    )
    q.add_argument("--truths", nargs="+", metavar="LIST", help="draw only these truths (comma-separated; default all)")
    q.add_argument("--keep-reports", action="store_true", help="write every dataset's report")
    q.add_argument(
        "--laws",
        metavar="SET",
        default="all",
        help="--generator independent: the rig's law set the effects are drawn from (maglev_ocp.rigsim.draw.LAW_SETS: "
        "all: the first families and issue 27's; old, new; v3, v4, ...: one set alone, maglev_ocp.rigsim.laws_vN; "
        "default all)",
    )
    q.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="local worker processes (Dask) the datasets are spread over, 1..256; 1 runs in-process; the "
        "result does not depend on it (default: CPU count)",
    )
    _analysis_flags(q)
    _generator_flags(q)
    _seed(q)
    q.set_defaults(handler=lambda a: _selftest(_common(a)))


def _register_generate(modes) -> None:
    q = _mode(
        modes,
        "generate",
        "write a diagnosis dataset from a plant with known effects",
        "maglev diagnose generate data/friction --effect friction --seed 3",
    )
    q.add_argument("generate", metavar="DIR", help="dataset folder to write")
    _effect_flags(
        q,
        "effect in the plant (library generator: one library effect or none; independent generator: "
        "comma-separated rigsim effects, e.g. cogging,friction, or none)",
    )
    q.add_argument(
        "--extra",
        choices=("vibration", "guide_ripple"),
        help="add an effect outside the library (7.3 Hz vibration, 8.6 mm guide ripple)",
    )
    _generator_flags(q)
    _seed(q)
    q.set_defaults(handler=lambda a: _generate(_common(a)))


def _register_closed_loop(modes) -> None:
    q = _mode(
        modes,
        "closed-loop",
        "what a diagnosis changes in closed loop: --from REPORT, or --effect NAME",
        "maglev diagnose closed-loop scenarios/tour_fl.yaml --from results/diagnosis/report.json --out cl",
    )
    q.add_argument("scenario_path", metavar="SCENARIO", help="scenario YAML")
    q.add_argument("--from", dest="from_report", metavar="REPORT", help="the diagnosis report.json")
    _effect_flags(q, "the effect on the rig (without --from: fitted on generated data, or --fitted-from)")
    q.add_argument("--fitted-from", metavar="REPORT", help="with --effect: take the fitted effect from this report")
    q.add_argument("--out", metavar="DIR", help="write closed_loop.json / closed_loop.md here")
    q.add_argument("--runs", type=int, default=6, metavar="N", help="--effect: runs of the fit's data (default 6)")
    q.add_argument("--duration", type=float, default=10.0, metavar="S", help="--effect: seconds per run (10)")
    q.set_defaults(handler=_closed_loop_mode)


#: The flags that chose a mode before the subcommands, and the subcommand that replaces each.
OLD_MODE_FLAGS: dict[str, str] = {
    "--selftest": "selftest N",
    "--generate": "generate DIR",
    "--closed-loop": "closed-loop SCENARIO --from REPORT",
    "--scenario": "closed-loop SCENARIO --effect NAME",
}


def old_form_error(argv: list[str]) -> str | None:
    """What to write instead of a pre-subcommand ``maglev diagnose`` command line (None: not an old form)."""
    if not argv or argv[0] != "diagnose" or len(argv) < 2 or argv[1] in (*MODES, "-h", "--help"):
        return None
    for flag, new in OLD_MODE_FLAGS.items():
        if flag in argv[1:]:
            return f"'diagnose {flag}' is now a subcommand: maglev diagnose {new} (see maglev diagnose --help)"
    if not argv[1].startswith("-"):
        return f"name the mode: maglev diagnose run {argv[1]} --out DIR (see maglev diagnose --help)"
    return None


def _no_mode(args: argparse.Namespace) -> int:
    raise UserError(f"give a mode: maglev diagnose {{{'|'.join(MODES)}}} ... (see maglev diagnose --help)")


def _common(args: argparse.Namespace) -> argparse.Namespace:
    """Checks shared by the modes (seed, lists) and the attributes a mode does not have, at their defaults."""
    from . import MAX_SEED, check_count, parse_list

    for name, default in (
        ("candidates", None),
        ("truths", None),
        ("effect_param", []),
        ("seed", 0),
        ("fc", 15.0),
        ("loop", "auto"),
        ("extra", None),
        ("effect", None),
    ):
        if not hasattr(args, name):
            setattr(args, name, default)
    check_count("--seed", args.seed, 0, MAX_SEED)
    args.candidates = parse_list("--candidates", args.candidates) if args.candidates else None
    args.truths = parse_list("--truths", args.truths) if args.truths else None
    args.effect_param = parse_list("--effect-param", args.effect_param) if args.effect_param else []
    return args


def _closed_loop_mode(args: argparse.Namespace) -> int:
    """``closed-loop SCENARIO``: exactly one of ``--from REPORT`` and ``--effect NAME``."""
    _common(args)
    if (args.from_report is None) == (args.effect is None):
        raise UserError("closed-loop: give exactly one of --from REPORT (a diagnosis) or --effect NAME")
    if args.from_report is not None:
        if args.fitted_from or args.effect_param:
            raise UserError("--from: --fitted-from and --effect-param go with --effect, not with --from")
        args.closed_loop = args.scenario_path
        return _closed_loop(args)
    args.scenario = args.scenario_path
    return _scenario(args)


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
    from pydantic import ValidationError

    from ..diagnosis.diagnose import LIBRARY, DiagnoseSettings

    check_range("--fc", args.fc, 0.5, 200.0, "Hz", lo_open=True)
    if args.candidates:
        bad = [c for c in args.candidates if c not in LIBRARY]
        if bad:
            raise UserError(f"--candidates: unknown {bad}; choose from {', '.join(LIBRARY)}")
    exclude: dict[str, list[str]] = {}
    for item in getattr(args, "exclude_law", None) or []:
        effect, sep, member = item.partition(":")
        if not sep or not member.strip():
            raise UserError(f"--exclude-law: expected EFFECT:MEMBER (e.g. 'end_effect:two ends'), got {item!r}")
        exclude.setdefault(effect.strip(), []).append(member.strip())
    try:
        return DiagnoseSettings(fc_hz=args.fc, candidates=args.candidates, seed=args.seed, exclude_laws=exclude, **kw)
    except ValidationError as e:  # an unknown effect or member: one line with the allowed ones
        raise UserError(
            "--exclude-law: " + "; ".join(str(x["msg"]).removeprefix("Value error, ") for x in e.errors())
        ) from None


def _generator(args):
    from ..diagnosis.generate import GeneratorSettings

    if not 2 <= args.runs <= 100:
        raise UserError(f"--runs: {args.runs} is outside 2..100")
    check_range("--duration", args.duration, 2.0, 600.0, "s")
    return GeneratorSettings(n_runs=args.runs, run_duration=args.duration, loop=getattr(args, "loop", "auto"))


def _dataset(args) -> int:
    from ..diagnosis import diagnose
    from ..diagnosis.active import write_experiment
    from ..diagnosis.pool import pool_datasets
    from ..diagnosis.report import write_report
    from ..output import check_output_dir, replace_dir
    from ..riglog import read_dataset
    from . import load_model_params

    check_output_dir(args.out, expect=REPORT_FILES)
    folders = [Path(f) for f in args.dataset]
    for folder in folders:
        if not (folder / "dataset.yaml").is_file():
            raise UserError(f"{folder}: not a dataset folder (no dataset.yaml)")
    if len({f.resolve() for f in folders}) < len(folders):
        raise UserError("DATASET: a dataset is given twice (its runs would count twice)")
    params = load_model_params(args.given) if args.given else None
    st = _settings(args)
    ds = pool_datasets([read_dataset(f) for f in folders])
    d = diagnose(ds, params=params, settings=st, progress=not args.quiet)
    print(d.table())
    with replace_dir(args.out) as tmp:
        write_report(d, tmp, figures=not args.no_figures, progress=not args.quiet)
        plan = write_experiment(d, tmp, progress=not args.quiet)
    print(f"report: {Path(args.out) / 'report.md'}")
    if plan is not None:
        print(
            f"confusable: {' | '.join(plan.slot)}; run plan {Path(args.out) / 'experiment.yaml'} "
            f"({plan.excitation}, predicted SNR {plan.predicted_snr:.1f}); run it, then diagnose both datasets"
        )
    return 0


def _selftest(args) -> int:
    from ..diagnosis.selftest import DRAWS, SelftestSettings, run_selftest
    from . import MAX_SELFTEST_DATASETS, MAX_WORKERS, check_count

    check_count("N", args.selftest, 1, MAX_SELFTEST_DATASETS)
    if args.workers is not None:
        check_count("--workers", args.workers, 1, MAX_WORKERS)
    if args.plant == "independent":
        return _selftest_independent(args)
    if args.laws != "all":
        raise UserError("--laws: the law sets are the independent rig's; add --generator independent")
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
            res = run_fn(st, progress=not args.quiet, out_dir=tmp, keep_reports=args.keep_reports, workers=workers)
    else:
        res = run_fn(st, progress=not args.quiet, out_dir=None, keep_reports=args.keep_reports, workers=workers)
    print(res.table())
    if args.out:
        print(f"written: {Path(args.out) / 'selftest.md'}")
    return 0


def _selftest_independent(args) -> int:
    """``selftest N --generator independent``: the blind self-check on datasets of the independent rig."""
    from ..diagnosis.selftest import SelftestSettings
    from ..diagnosis.selftest_rig import run_rig_selftest
    from ..rigsim.draw import LAW_SETS

    if args.laws not in LAW_SETS:
        raise UserError(f"--laws: unknown law set {args.laws!r}; choose from {', '.join(LAW_SETS)}")
    if args.truths:
        raise UserError("--truths: the independent generator draws its own truths (none, 1-3 effects, out of library)")
    if args.baseline != "calibrated":
        raise UserError(
            "--baseline given: the independent generator's constants are off nominal; only 'calibrated' applies"
        )
    st = SelftestSettings(
        n=args.selftest,
        seed=args.seed,
        generator=_generator(args),
        diagnose=_settings(args, simulate=False),
        laws=args.laws,
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
    check_output_dir(args.generate, "DIR", expect=("dataset.yaml",))
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
        progress=not args.quiet,
    )
    with replace_dir(args.generate) as tmp:  # a generated dataset carries its truth: replaced whole, not appended
        gen.save(tmp)
    print(read_dataset(args.generate).table())
    print(f"written: {args.generate}")
    return 0


def _generate_independent(args) -> int:
    """``generate DIR --generator independent``: a dataset (and its truth.json) from the independent rig."""
    import json

    from ..output import check_output_dir, replace_dir
    from ..riglog import read_dataset
    from ..rigsim import RigSettings, generate

    if args.extra:
        raise UserError("--extra: the independent rig names its effects outside the library in --effect "
                        "(resonance, encoder_error, temperature_drift, cable)")  # fmt: skip
    effects = independent_effects(args.effect, args.effect_param)
    _generator(args)  # the same checks of --runs and --duration
    check_output_dir(args.generate, "DIR", expect=("dataset.yaml",))
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
        progress=not args.quiet,
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

    if not Path(args.closed_loop).is_file():
        raise UserError(f"{args.closed_loop}: no such scenario file")
    if not Path(args.from_report).is_file():
        raise UserError(f"{args.from_report}: no such report")
    if args.out:
        from ..output import check_output_dir

        check_output_dir(args.out, replaced=False, expect=("closed_loop.json", "closed_loop.md"))
    res = closed_loop_from_report(args.closed_loop, args.from_report, progress=not args.quiet)
    print(res.table())
    if args.out:
        res.save(args.out)
        print(f"written: {Path(args.out) / 'closed_loop.md'}")
    return 0
