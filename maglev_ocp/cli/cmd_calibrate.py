"""``maglev calibrate``: calibrate the model on a rig-log dataset (seed sections IV, V)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import UserError
from . import check_range


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
            "errors. Writes DIR/params.yaml, DIR/calibration.json, DIR/tables/ and the seed's figures,\n"
            "and prints a summary that says which parameters the data pins down poorly."
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
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev calibrate``."""
    from ..estimation.calibrate import calibrate
    from ..output import check_output_dir, replace_dir
    from ..params import NOMINAL
    from . import load_model_params

    for e in args.eps:
        check_range("--eps", e, 1e-5, 1.0)
    if not Path(args.dataset).exists():
        raise UserError(f"DATASET: {args.dataset}: no such folder")
    check_output_dir(args.out, expect=("params.yaml", "calibration.json"))
    prior = load_model_params(args.prior) if args.prior else NOMINAL
    res = calibrate(args.dataset, prior=prior, eps_list=tuple(args.eps), progress=not args.no_progress)
    with replace_dir(args.out) as tmp:
        res.save(tmp, figures=not args.no_figures)
    print(res.table())
    print(
        f"\ncalibration took {res.timing['total']:.1f} s; wrote {Path(args.out) / 'params.yaml'} and "
        f"{Path(args.out) / 'calibration.json'}"
    )
    return 0
