"""``maglev codegen``: C sources of one control step of each controller, with header, harness and Makefile."""

from __future__ import annotations

import argparse
import os
import time

# Importing maglev_ocp.codegen registers the C backend with the runner (maglev_ocp.runner.register_backend);
# the CLI imports every cmd_* module, so ``backend: c`` works for every command (run, campaign, bench, ...).
from ..codegen import KINDS, controller_codes
from ..codegen.build import build_folder
from ..codegen.sources import generate_sources
from ..codegen.templates import DEFAULT_CFLAGS
from ..errors import UserError


def register(sub) -> None:
    """Add the ``codegen`` subcommand."""
    from . import add_command

    p = add_command(
        sub,
        "codegen",
        help="generate self-contained C of the controllers' steps (+ header, harness, Makefile)",
        description=(
            "Generate, with CasADi's code generator, plain C (libm only, no malloc in a step) of one\n"
            "control step of each controller: the NMPC (observer, planner, RTI linearization, QP\n"
            "solve by fixed-budget ADMM, fallback, warm-start shift), feedback linearization\n"
            "(observer + law) and the observer alone; plus maglev_controller.h (memory layout, inputs, outputs,\n"
            "units), main.c (a harness that runs a controller over a rig-log CSV), a Makefile and a\n"
            "CMakeLists.txt. Controller settings come from a scenario (its controller block and\n"
            "controller_params) or a parameter file; the other controllers use their defaults.\n"
            "--out is required: nothing is written into the current directory by accident."
        ),
        example="maglev codegen --out build/controller_c --scenario scenarios/tour_nmpc.yaml --make",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (replaced whole)")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--scenario", default=None, metavar="FILE", help="scenario YAML: controller settings and params")
    src.add_argument(
        "--params",
        default=None,
        metavar="FILE",
        help="nominal constants: a parameter file (maglev-params/1; default: seed Table III)",
    )
    p.add_argument(
        "--controllers",
        default="nmpc,fl,observer",
        metavar="LIST",
        help="comma-separated subset of nmpc,fl,observer (default: all)",
    )
    p.add_argument("--cflags", default=None, metavar="FLAGS", help="default CFLAGS written into the Makefile")
    p.add_argument("--make", action="store_true", help="also build (make -j2) in the output folder")
    p.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev codegen``."""
    from ..output import check_output_dir, replace_dir
    from ..params import NOMINAL
    from . import load_model_params

    out = check_output_dir(
        args.out, expect=("maglev_controller.h", "Makefile")
    )  # before the (slow) code generation; refuses the current directory
    kinds = [s.strip() for s in args.controllers.split(",") if s.strip()]
    bad = [s for s in kinds if s not in KINDS]
    if bad or not kinds:
        raise UserError(f"--controllers: {','.join(bad) or '(empty)'} not among {','.join(KINDS)}")
    if len(set(kinds)) != len(kinds):
        raise UserError("--controllers: a controller is listed twice")
    params, nmpc_s, fl_s, shaping = NOMINAL, None, None, None
    if args.scenario:
        from ..scenario import load_scenario

        sc = load_scenario(args.scenario)
        params = sc.controller_model_params()
        shaping = sc.reference.shaping
        if sc.controller.type == "nmpc":
            nmpc_s = sc.controller.settings
        elif sc.controller.type == "fl":
            fl_s = sc.controller.settings
    elif args.params:
        params = load_model_params(args.params)
    cflags = args.cflags if args.cflags is not None else os.environ.get("MAGLEV_CODEGEN_CFLAGS", DEFAULT_CFLAGS)
    if any(ch in cflags for ch in "\n;`$"):
        raise UserError(f"--cflags: {cflags!r} contains characters not allowed in a Makefile variable")
    t0 = time.perf_counter()
    codes = controller_codes(kinds, params, nmpc_s, fl_s, shaping)
    src = generate_sources(codes, cflags)
    with replace_dir(out) as tmp:  # the folder holds exactly these files: none of an earlier invocation
        src.save(tmp)
    t_gen = time.perf_counter() - t0
    print(src.table())
    nmpc = next((c for c in codes if c.kind == "nmpc"), None)
    if nmpc is not None:
        print(
            f"nmpc: horizon {nmpc.defines['HORIZON']}, reference mode "
            f"{'preview' if nmpc.defines['REF_MODE_PREVIEW'] else 'plan'}"
        )
    print(f"code generation of {', '.join(kinds)}: {t_gen:.1f} s (Functions built and C written) -> {out}")
    if args.make:
        res = build_folder(out, jobs=2)
        print(
            f"built in {res.seconds:.1f} s: {res.library.name}, {res.harness.name if res.harness else ''} "
            f"(CFLAGS={res.cflags!r})"
        )
    else:
        print(f"build: make -C {out} -j2     run: {out}/maglev_harness nmpc LOG.csv -o currents.csv")
    return 0
