"""``maglev calibrate``: calibrate the model on a rig-log dataset (seed sections IV, V)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError
from . import add_quiet, check_range


def register(sub) -> None:
    """Add the ``calibrate`` subcommand."""
    from . import add_command

    p = add_command(
        sub,
        "calibrate",
        help="calibrate C1..C4, xi0, ell on a rig-log dataset (seed's procedures + batch fit)",
        description=(
            "Run the seed's calibration procedures that the dataset's runs allow (V.A parabolas at\n"
            "locked gaps, V.B hover with d locked at 0, V.C cogging with d locked at 3 t1/2, V.D free\n"
            "runs; NPFISI at eps 0.001, 0.01, 0.05) and the batch fit of all parameters with standard\n"
            "errors. Writes DIR/model.yaml (a model file: use it in a scenario with\n"
            "controller: {model: DIR/model.yaml}, a relative path read from the scenario file's folder),\n"
            "DIR/calibration.json, DIR/tables/ and the seed's figures, and prints a summary that says\n"
            "which parameters the data pins down poorly.\n\n"
            "Data that cannot identify a constant (relative standard error above 10 %, an ill-conditioned\n"
            "information matrix, a constant at its bound, or an unconverged fit) are refused: exit 2, one\n"
            "line naming the constants and the reason, nothing written. --force writes the result anyway,\n"
            "with model.yaml marked 'trusted: false' (every loader then warns)."
        ),
        example="maglev calibrate data/seed_cal --out results/my_calibration",
    )
    p.add_argument("dataset", metavar="DATASET", help="rig-log dataset folder (maglev-rig-log/1)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder")
    p.add_argument("--prior", default=None, metavar="FILE", help="parameter YAML to start from (default: Table III)")
    p.add_argument(
        "--eps",
        nargs="+",
        type=float,
        default=[0.001, 0.01, 0.05],
        metavar="EPS",
        help="NPFISI eps values (must include 0.01; default: 0.001 0.01 0.05)",
    )
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument(
        "--force",
        action="store_true",
        help="write the result even when the data cannot identify the constants (model.yaml marked trusted: false)",
    )
    add_quiet(p)
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev calibrate``."""
    from ..estimation.calibrate import calibrate
    from ..output import check_output_dir, replace_dir
    from ..params import NOMINAL, model_file_instruction
    from . import load_model_params

    for e in args.eps:
        check_range("--eps", e, 1e-5, 1.0)
    if not Path(args.dataset).exists():
        raise UserError(f"DATASET: {args.dataset}: no such folder")
    check_output_dir(args.out, expect=("model.yaml", "params.yaml", "calibration.json"))
    prior = load_model_params(args.prior) if args.prior else NOMINAL
    res = calibrate(args.dataset, prior=prior, eps_list=tuple(args.eps), progress=not args.quiet)
    problems = res.trust_problems()
    if problems and not args.force:
        raise UserError(
            f"{args.dataset}: these runs cannot identify the constants: {'; '.join(problems)}; nothing written "
            "(record runs that excite them, e.g. maglev simulate --experiment seed-calibration, or --force to "
            "write a model file marked untrusted)"
        )
    with replace_dir(args.out) as tmp:
        res.save(tmp, figures=not args.no_figures)
    print(res.table())
    model = Path(args.out) / "model.yaml"
    print(f"\ncalibration took {res.timing['total']:.1f} s; wrote {model} and {Path(args.out) / 'calibration.json'}")
    if problems:
        print(f"UNTRUSTED (--force): {'; '.join(problems)}; {model} is marked trusted: false")
    print(f"{model}: {model_file_instruction(str(model.resolve()))}")  # absolute: right from any scenario folder
    return 0
