"""``maglev model``: the operating table of the model over the gap."""

from __future__ import annotations

import argparse
import json

from . import check_range

#: Figure formats ``--plot`` writes (by the file's suffix).
PLOT_SUFFIXES: tuple[str, ...] = (".png", ".pdf", ".svg", ".jpg", ".jpeg", ".eps", ".ps", ".tif", ".tiff")


def register(sub) -> None:
    """Add the ``model`` subcommand."""
    from . import add_command

    p = add_command(
        sub,
        "model",
        help="print the model's operating table over the gap",
        description=(
            "Print, for each gap, the slot factor lam, Carter's coefficient Kc, the PM\n"
            "field B, the equilibrium current i_d (seed eq. (8), d = 0, no cogging),\n"
            "L1 = C1*f1 and the open-loop vertical pole at hover."
        ),
        example="maglev model --gaps 10 15 20 25 --json",
    )
    p.add_argument(
        "--gaps",
        nargs="+",
        type=float,
        default=[10, 15, 20, 25],
        metavar="MM",
        help="gaps in mm (default: 10 15 20 25)",
    )
    p.add_argument(
        "--params",
        default=None,
        metavar="FILE",
        help="nominal constants: a parameter file (maglev-params/1; default: seed Table III)",
    )
    p.add_argument("--json", action="store_true", help="print JSON instead of a text table")
    p.add_argument(
        "--plot",
        default=None,
        metavar="PNG",
        help="also plot the table over 8..32 mm to this file (.png, .pdf, .svg, ...)",
    )
    p.set_defaults(handler=run)


def table(gaps_mm, params) -> list[dict[str, float]]:
    """Operating table rows for ``gaps_mm`` (see :meth:`MaglevModel.operating_point`)."""
    from ..model import get_model

    m = get_model()
    return [m.operating_point(g * 1e-3, params) for g in gaps_mm]


def format_table(rows: list[dict[str, float]]) -> str:
    """Fixed-width text table with units."""
    head = (
        f"{'g [mm]':>7} {'lam':>7} {'Kc':>7} {'B [T]':>7} {'i_d,eq [A]':>11} {'L1 [m/s^2/A]':>13} {'pole [rad/s]':>13}"
    )
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['g_mm']:7.2f} {r['lam']:7.4f} {r['Kc']:7.4f} {r['B_T']:7.4f} {r['i_d_eq_A']:11.4f} "
            f"{r['L1']:13.3f} {r['pole_rad_s']:13.2f}"
        )
    return "\n".join(lines)


def plot_table(path: str, params) -> None:
    """Plot the operating quantities over the whole stroke (8..32 mm)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from ..output import atomic_write_bytes

    gs = np.linspace(8.0, 32.0, 97)
    rows = table(gs, params)
    fig, ax = plt.subplots(2, 2, figsize=(9, 6), sharex=True)
    for a, key, lab in [
        (ax[0, 0], "B_T", "B(g) [T]"),
        (ax[0, 1], "i_d_eq_A", "equilibrium i_d [A]"),
        (ax[1, 0], "L1", "L1 = C1 f1 [m/s^2/A]"),
        (ax[1, 1], "pole_rad_s", "open-loop pole [rad/s]"),
    ]:
        a.plot(gs, [r[key] for r in rows])
        a.set_ylabel(lab)
        a.grid(True, alpha=0.3)
        a.axvspan(15, 25, color="tab:green", alpha=0.08, label="tracking envelope")
    for a in ax[1]:
        a.set_xlabel("gap g [mm]")
    ax[0, 0].legend()
    fig.suptitle("Operating table of the shared model")
    fig.tight_layout()
    atomic_write_bytes(path, fig)
    plt.close(fig)


def run(args: argparse.Namespace) -> int:
    """Handler of ``maglev model``."""
    from ..output import check_output_file
    from ..params import NOMINAL
    from . import load_model_params

    if args.plot is not None:
        check_output_file(args.plot, "--plot", PLOT_SUFFIXES)
    params = load_model_params(args.params) if args.params else NOMINAL
    for g in args.gaps:
        check_range("--gaps", g, 1.0, 100.0, "mm")
    rows = table(args.gaps, params)
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        print(format_table(rows))
    if args.plot:
        plot_table(args.plot, params)
    return 0
