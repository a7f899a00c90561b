"""``maglev analyze``: gain, phase, disk and delay margins of the controllers over the operating envelope."""

from __future__ import annotations

import argparse
import json
import sys

from . import add_quiet, check_range

#: Files a results folder of ``maglev analyze`` holds (an existing folder must hold one to be replaced).
RESULT_FILES: tuple[str, ...] = ("margins.md", "margins.json", "margins.csv")


def register(sub) -> None:
    """Add the ``analyze`` subcommand."""
    from . import add_command

    p = add_command(
        sub,
        "analyze",
        help="loop margins of the controllers over a grid of operating points",
        description=(
            "Linearize each controller (its observer, integrators, predictor and warm start at their\n"
            "steady state) and the plant (shared model, amplifier lag, computation delay) at hover points\n"
            "g x d, break each axis' loop at the plant input and output (the other loop closed), and\n"
            "report gain, phase, disk and delay margins, |S| and |T| peaks and the bandwidth (python-control).\n"
            "The delay margin is cross-checked by closed-loop simulation with an added delay.\n"
            "Writes margins.md/.csv/.json and Bode, Nyquist and |S|/|T| figures to --out."
        ),
        example="maglev analyze --controllers fl,nmpc --gaps 15 20 25 --positions -40 0 40 --out results/analysis",
    )
    p.add_argument(
        "--controllers",
        nargs="+",
        default=["fl"],
        metavar="LIST",
        help="comma-separated subset of fl,nmpc,pid (default: fl)",
    )
    p.add_argument("--controller", dest="controllers", nargs="+", help=argparse.SUPPRESS)  # the old spelling
    p.add_argument("--scenario", default=None, metavar="YAML", help="take controller and plant from a scenario")
    p.add_argument("--gaps", nargs="+", type=float, default=[15, 20, 25], metavar="MM", help="gaps [mm]")
    p.add_argument("--positions", nargs="+", type=float, default=[-40, 0, 40], metavar="MM", help="positions d [mm]")
    p.add_argument("--profile", default="default", help="plant profile for the amplifier lag and delay")
    p.add_argument(
        "--delay-samples",
        type=int,
        default=None,
        metavar="N",
        help="computation delay of the loop [periods] (default: the profile's); controllers with a\n"
        "delay_samples setting compensate it unless --set gives another value",
    )
    p.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="controller setting (YAML value) for every --controllers type, e.g. --set omega_g=150; repeatable",
    )
    p.add_argument(
        "--check-delay",
        choices=("none", "center", "all"),
        default="center",
        help="simulate the delay margin at the grid point nearest 20 mm / 0 (center), everywhere, or not",
    )
    p.add_argument("--out", default=None, metavar="DIR", help="write tables and figures here")
    p.add_argument("--no-figures", action="store_true", help="tables only")
    p.add_argument("--json", action="store_true", help="print the margins as JSON instead of Markdown")
    add_quiet(p)
    p.set_defaults(handler=run)


def _settings_overrides(items: list[str]) -> dict:
    from ..config import parse_yaml_text
    from ..errors import UserError

    out = {}
    for item in items:
        key, sep, val = item.partition("=")
        if not sep or not key.strip():
            raise UserError(f"--set: expected KEY=VALUE, got {item!r}")
        out[key.strip()] = parse_yaml_text(val, f"--set {key.strip()}")
    return out


def _factories(args, delay: int):
    """Controller factories by label, and the parameters their model (and the analysis plant) uses."""
    from ..config import parse_model
    from ..errors import UserError
    from ..params import NOMINAL
    from ..scenario import CONTROLLERS, controller_classes, load_scenario

    if args.scenario:
        sc = load_scenario(args.scenario)
        _, cls = controller_classes(sc.controller.type)
        settings, params = sc.controller.settings, sc.controller_model_params()
        return {sc.controller.type: (lambda: cls(settings=settings, params=params))}, params, sc
    overrides = _settings_overrides(args.set)
    out = {}
    from . import parse_list

    for ctype in dict.fromkeys(parse_list("--controllers", args.controllers)):
        if ctype not in CONTROLLERS:
            raise UserError(f"--controllers: unknown type {ctype!r}; choose from {', '.join(CONTROLLERS)}")
        settings_cls, cls = controller_classes(ctype)
        data = dict(overrides)
        if "delay_samples" in settings_cls.model_fields and "delay_samples" not in data:
            data["delay_samples"] = delay
        settings = parse_model(settings_cls, data, f"--set ({ctype})")
        out[ctype] = lambda c=cls, s=settings: c(settings=s, params=NOMINAL)
    return out, NOMINAL, None


def _delay_checks(mode: str, factories: dict, plant, results: list, say) -> list:
    """The delay margin cross-checked by simulation (``--check-delay``: none, center or all grid points)."""
    from ..analysis.report import delay_cross_check

    checks: list = []
    if mode == "none":
        return checks
    for name, make in factories.items():
        prs = [pr for pr in results if pr.controller == name]
        if mode == "center":
            prs = [min(prs, key=lambda pr: (abs(pr.g - 0.020) / 0.005) ** 2 + (abs(pr.d) / 0.04) ** 2)]
        for pr in prs:
            for axis in ("g", "d"):
                c = delay_cross_check(make, plant, pr, axis)
                checks.append(c)
                say(
                    f"{name} delay check g = {pr.g * 1e3:.0f} mm, d = {pr.d * 1e3:.0f} mm, {axis}: computed "
                    f"{c.computed_samples:.3f}, simulated {c.simulated.delay_samples:.3f} samples"
                )
    return checks


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev analyze``."""
    from ..analysis.plant_model import AnalysisPlant
    from ..analysis.report import analyze_grid, markdown_report, write_report
    from ..constants import d_stop, g_stop
    from ..errors import UserError
    from ..output import check_output_dir, replace_dir
    from ..plant.config import PlantConfig

    for g in args.gaps:
        check_range("--gaps", g, g_stop[0] * 1e3, g_stop[1] * 1e3, "mm")
    for d in args.positions:
        check_range("--positions", d, d_stop[0] * 1e3, d_stop[1] * 1e3, "mm")
    if args.delay_samples is not None:
        check_range("--delay-samples", args.delay_samples, 0, 10)
    if args.out:
        check_output_dir(args.out, expect=RESULT_FILES)
    cfg = None
    if args.scenario:
        from ..scenario import load_scenario

        cfg = load_scenario(args.scenario).plant_config()
    else:
        cfg = PlantConfig.from_profile(args.profile)
    lag = cfg.effects.amplifier_lag
    delay = cfg.total_delay() if args.delay_samples is None else int(args.delay_samples)
    factories, params, _ = _factories(args, delay)
    plant = AnalysisPlant(params=params, lag_hz=lag.bandwidth_hz if lag.enabled else None, delay_samples=delay)
    gaps = [g * 1e-3 for g in args.gaps]
    positions = [d * 1e-3 for d in args.positions]

    def say(s: str) -> None:
        if not args.quiet:
            print(f"maglev analyze: {s}", file=sys.stderr, flush=True)

    try:
        results = analyze_grid(factories, plant, gaps, positions, progress=say)
    except (RuntimeError, ValueError) as err:
        raise UserError(f"the loop could not be linearized: {err}") from None
    checks = _delay_checks(args.check_delay, factories, plant, results, say)
    setup = {
        "controllers": ", ".join(factories),
        "plant": (
            f"shared model at the controller's parameters, amplifier lag "
            f"{f'{plant.lag_hz:g} Hz' if plant.lag_hz else 'off'}, computation delay {delay} samples"
        ),
        "grid": f"g = {args.gaps} mm x d = {args.positions} mm",
        "scenario": args.scenario or "-",
        "settings": ", ".join(args.set) or "defaults",
    }
    Ts = plant.Ts
    if args.out:
        with replace_dir(args.out) as tmp:
            write_report(results, tmp, Ts=Ts, setup=setup, checks=checks, figures=not args.no_figures)
        say(f"wrote {args.out}/margins.md, margins.csv, margins.json" + ("" if args.no_figures else " and figures"))
    if args.json:
        rows = [lr.row(Ts) for pr in results for lr in pr.loops]
        print(json.dumps({"margins": rows, "delay_checks": [c.row() for c in checks]}, indent=1))
    else:
        print(markdown_report(results, Ts=Ts, setup=setup, checks=checks))
    unstable = [pr for pr in results if pr.closed_loop_radius >= 1.0]
    return 1 if unstable else 0
