"""Closed-loop view of a gap: the same scenario on the model, on the rig with an effect, and compensated.

Three runs of one scenario (:func:`maglev_ocp.runner.run_scenario`, the one closed loop
of :mod:`maglev_ocp.loop`, same seed):

``model``
    the scenario's plant *without* the effect: what the controller's model
    predicts the loop does;
``rig``
    the plant *with* the effect, same controller: the gap in the closed-loop
    metrics (settling time, steady rms error);
``compensated``
    the plant with the effect, and the controller's model carrying the
    *fitted* effect.

How the controller's model carries an effect without touching the
controller: :class:`EffectCompensation` wraps any controller. After the
controller has chosen ``u_c`` for its own model, the wrapper finds the
current ``u`` for which the augmented model (the same candidate expressions
the diagnosis fitted) gives the acceleration the controller asked of its
model, ``a_aug(x_hat, u) = a_M(x_hat, u_c)``, by Newton's method on the 2x2
system (a CasADi Function). For a feedback-
linearizing controller this is exactly the inverse of the augmented model;
for the others it makes the rig behave like their model. The amplifier lag
is carried by a first-order lead of the fitted effective delay (the inverse
of the lag below its bandwidth).

The fitted effect comes from a diagnosis: by default a diagnosis dataset is
generated on the scenario's plant with the effect and diagnosed (the
candidate of that effect is taken, whatever the verdict), or the fitted
parameters are read from a ``report.json``.
"""

from __future__ import annotations

import functools
import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np

from .. import constants as k
from ..blocks import ControlOutput, Measurement, Reference
from ..effects import EFFECTS
from ..errors import UserError
from ..output import atomic_write_bytes, atomic_write_text, make_dir
from ..params import Params
from ..plant.config import deep_merge
from ..runner import _as_scenario, build_controller, run_scenario
from ..scenario import scenario_from_dict
from ..signals import PARAM_NAMES
from .diagnose import DiagnoseSettings, diagnose
from .fit import _accel_function
from .generate import GeneratorSettings, generate_dataset
from .library import CandidateSpec, library_specs

if TYPE_CHECKING:
    from matplotlib.figure import Figure


@functools.lru_cache(maxsize=32)
def _compensator(spec: CandidateSpec) -> ca.Function:
    """``(x, u_c, u_prev, p_model, p_aug, w) -> u``: Newton solve of ``a_aug(x, u) = a_model(x, u_c)``."""
    acc = _accel_function(spec)
    base = _accel_function(CandidateSpec("baseline"))
    x = ca.SX.sym("x", 4)
    uc = ca.SX.sym("uc", 2)
    up = ca.SX.sym("up", 2)
    pm = ca.SX.sym("pm", acc.size1_in(1))
    pa = ca.SX.sym("pa", acc.size1_in(1))
    w = ca.SX.sym("w", acc.size1_in(2))
    target = base(ca.vertcat(x, uc, up), pm, ca.SX.zeros(0, 1))
    u = ca.SX.sym("u", 2)
    r = acc(ca.vertcat(x, u, up), pa, w) - target
    J = ca.jacobian(r, u)
    step = ca.Function("newton_step", [u, x, uc, up, pm, pa, w], [u - ca.solve(J, r)])
    uk = uc
    for _ in range(4):
        uk = step(uk, x, uc, up, pm, pa, w)
    return ca.Function(
        "compensate", [x, uc, up, pm, pa, w], [uk], ["x", "u_c", "u_prev", "p_model", "p_aug", "w"], ["u"]
    )


def _pick(obj: Any, *names: str) -> dict[str, Any]:
    """``{name: obj.name}`` for each of ``names``, in order."""
    return {n: getattr(obj, n) for n in names}


def _save_view(
    out_dir: str | os.PathLike, doc: dict, title: str, table: str, figure: Callable[[], Figure | None]
) -> Path:
    """Write ``closed_loop.json``, ``closed_loop.md`` (``title`` over ``table``) and ``closed_loop.png``.

    ``figure()`` draws the figure (None: there is none to draw).
    """
    out = make_dir(out_dir)
    atomic_write_text(out / "closed_loop.json", json.dumps(doc, indent=2, default=_jsonable))
    atomic_write_text(out / "closed_loop.md", f"# {title}\n\n```\n{table}\n```\n\n![closed loop](closed_loop.png)\n")
    fig = figure()
    if fig is not None:
        import matplotlib.pyplot as plt

        atomic_write_bytes(out / "closed_loop.png", fig)
        plt.close(fig)
    return out


class EffectCompensation:
    """A controller whose model carries a fitted effect (wraps any :class:`~maglev_ocp.blocks.Controller`).

    Parameters
    ----------
    controller : Controller
        The wrapped controller (its own model unchanged).
    spec : CandidateSpec
        The fitted candidate (effect expressions).
    w : ndarray
        Its fitted values.
    p_model : Params
        The controller's model parameters.
    p_aug : ndarray
        Parameter vector of the augmented model (the diagnosis' baseline with any fitted entries).
    lag_delay : float
        Fitted effective delay of the amplifier [s] (0: none); compensated by a lead.
    """

    def __init__(
        self,
        controller,
        spec: CandidateSpec,
        w: np.ndarray,
        p_model: Params,
        p_aug: np.ndarray,
        lag_delay: float = 0.0,
        Ts: float = k.Ts,
    ):
        self.inner = controller
        self.name = f"{getattr(controller, 'name', 'controller')}+{spec.name}"
        self.spec = spec
        self.w = np.asarray(w, float)
        self.pm = p_model.vector()
        self.pa = np.asarray(p_aug, float)
        self.static = bool(spec.effects) or bool(spec.free)
        self.F = _compensator(spec) if self.static else None
        self.lead = lag_delay / Ts
        self._uc_prev = None
        self._u_prev = np.zeros(2)

    def __getattr__(self, item: str) -> Any:  # forward set_reference_plan etc.
        return getattr(self.inner, item)

    def reset(self, y0: Measurement, ref: Reference) -> None:
        """Reset the wrapped controller."""
        self.inner.reset(y0, ref)
        self._uc_prev = None
        self._u_prev = np.zeros(2)

    def step(self, y: Measurement, ref: Reference) -> ControlOutput:
        """The wrapped controller's step, its current mapped through the augmented model's inverse."""
        out = self.inner.step(y, ref)
        uc = np.asarray(out.u, float)
        u = uc
        if self.static and out.x_hat is not None:
            sol = np.asarray(self.F(out.x_hat, uc, self._u_prev, self.pm, self.pa, self.w)).ravel()
            if np.all(np.isfinite(sol)):
                u = sol
        if self.lead > 0:
            prev = self._uc_prev if self._uc_prev is not None else uc
            u = u + self.lead * (uc - prev)
            self._uc_prev = uc
        u = _limit(u)
        self._u_prev = u
        stats = dict(out.stats)
        stats["compensation_A"] = float(np.hypot(*(u - uc)))
        return ControlOutput(u=u, x_hat=out.x_hat, stats=stats)


def _limit(u: np.ndarray) -> np.ndarray:
    i_d = float(np.clip(u[1], -k.i_axis_max, k.i_axis_max))
    q_max = min(k.i_axis_max, math.sqrt(max(k.i_amp_max**2 - i_d**2, 0.0)))
    return np.array([float(np.clip(u[0], -q_max, q_max)), i_d])


@dataclass
class ClosedLoopView:
    """Closed-loop metrics of the three runs.

    Attributes
    ----------
    scenario : str
        Scenario name.
    effect : str
        The effect.
    plant_effect : dict
        The effect's parameters in the plant.
    fitted : dict
        The fitted parameters the compensated controller carries.
    metrics : dict
        ``{run: metrics dict}`` for ``model``, ``rig`` and ``compensated``.
    """

    scenario: str
    effect: str
    plant_effect: dict
    fitted: dict
    metrics: dict[str, dict]
    logs: dict[str, dict] = field(default_factory=dict)

    KEYS = ("max_settle_time_s", "max_rms_error_g_m", "max_rms_error_d_m", "all_settled", "max_current_A")

    def rows(self) -> list[dict]:
        """One row per run with the headline metrics."""
        out = []
        for run, m in self.metrics.items():
            row = {"run": run}
            row.update({kk: m.get(kk) for kk in self.KEYS})
            tg = m.get("targets", [])
            fe = [max(abs(t["final_error_g_m"]), abs(t["final_error_d_m"])) for t in tg]
            row["max_final_error_m"] = max(fe) if fe else None
            out.append(row)
        return out

    def table(self) -> str:
        """Text table of the three runs."""
        head = (
            f"{'run':<12} {'settled':>7} {'max settle [s]':>14} {'rms g [um]':>10} {'rms d [um]':>10} "
            f"{'final err [um]':>14} {'max |i| [A]':>11}"
        )
        lines = [f"scenario {self.scenario}, effect {self.effect}", head, "-" * len(head)]

        def f(v, s=1.0, fmt="{:.2f}"):
            return "-" if v is None else fmt.format(v * s)

        for r in self.rows():
            lines.append(
                f"{r['run']:<12} {bool(r['all_settled'])!s:>7} {f(r['max_settle_time_s'], 1, '{:.3f}'):>14} "
                f"{f(r['max_rms_error_g_m'], 1e6):>10} {f(r['max_rms_error_d_m'], 1e6):>10} "
                f"{f(r['max_final_error_m'], 1e6):>14} {f(r['max_current_A']):>11}"
            )
        lines.append(
            "fitted: " + ", ".join(f"{kk}={v:.4g}" for kk, v in self.fitted.items() if isinstance(v, (int, float)))
        )
        return "\n".join(lines)

    def save(self, out_dir: str | os.PathLike) -> Path:
        """Write ``closed_loop.json``, ``closed_loop.md`` and ``closed_loop.png``."""
        doc = {
            **_pick(self, "scenario", "effect", "plant_effect", "fitted"),
            "runs": self.rows(),
            "metrics": self.metrics,
        }
        return _save_view(out_dir, doc, "Closed-loop view", self.table(), self.figure)

    def figure(self) -> Figure | None:
        """Tracking error of every run (None without logs)."""
        if self.logs:
            import matplotlib.pyplot as plt

            fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
            for run, cols in self.logs.items():
                t = cols["t"]
                ax[0].plot(t, (cols["g_true"] - cols["g_ref"]) * 1e6, lw=0.8, label=run)
                ax[1].plot(t, (cols["d_true"] - cols["d_ref"]) * 1e6, lw=0.8, label=run)
            ax[0].set_ylabel("gap error g - g_ref [um]")
            ax[1].set_ylabel("position error d - d_ref [um]")
            ax[1].set_xlabel("time t [s]")
            ax[0].legend(fontsize=8)
            ax[0].set_title(f"{self.scenario}: tracking error with and without {self.effect}")
            fig.tight_layout()
            return fig
        return None


def _jsonable(v):
    if isinstance(v, (np.floating, np.integer)):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return str(v)


def fitted_from_report(path: str | os.PathLike, effect: str) -> dict[str, float]:
    """Fitted parameters of ``effect`` from a diagnosis ``report.json`` (UserError if absent)."""
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise UserError(f"{path}: cannot read the diagnosis report: {err}") from None
    for e in doc.get("effects", []):
        if e.get("name") == effect:
            return {kk: float(v) for kk, v in e.get("params", {}).items() if v is not None}
    raise UserError(f"{path}: effects: no fitted '{effect}' in this report")


def _spec_values(spec: CandidateSpec, fitted: dict[str, float], p_base: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Fitted-value vector of ``spec`` and the augmented parameter vector from readable names."""
    w = []
    p = np.array(p_base, float)
    for f in spec.free:
        name = f.key.split(".", 1)[1]
        v = fitted.get(name, fitted.get(f.key, f.start))
        w.append(float(v))
        if f.key.startswith("p."):
            p[PARAM_NAMES.index(name)] = float(v)
    return np.array(w), p


def closed_loop_view(
    scenario,
    effect: str,
    effect_params: dict[str, float] | None = None,
    fitted: dict[str, float] | None = None,
    seed: int | None = None,
    progress: bool = False,
    fit_settings=None,
) -> ClosedLoopView:
    """Run the scenario on the model, on the rig with ``effect``, and with the fitted effect compensated.

    Parameters
    ----------
    scenario : Scenario, dict or path
        The scenario.
    effect : str
        Library effect put into the plant.
    effect_params : dict, optional
        Its parameters in the plant (default: the library's defaults; for
        ``cogging`` the seed's law with ``xi0``/``ell`` in the plant parameters).
    fitted : dict, optional
        Fitted parameters (readable names, as in ``report.json``); default:
        diagnose a dataset generated on the scenario's plant with the effect.
    seed : int, optional
        Replace the scenario's seed.
    progress : bool
        Progress bars.
    fit_settings : GeneratorSettings, optional
        Size of the generated diagnosis dataset.
    """
    if effect not in EFFECTS:
        raise UserError(f"--effect: unknown effect {effect!r}; choose from {', '.join(EFFECTS)}")
    sc = _as_scenario(scenario).with_seed(seed)
    eff = dict(EFFECTS[effect].defaults())
    eff.update(effect_params or {})
    bad = set(eff) - set(EFFECTS[effect].param_names()) - ({"xi0", "ell"} if effect == "cogging" else set())
    if bad:
        raise UserError(
            f"--effect-param: {effect} has no parameters {sorted(bad)}; it has "
            f"{', '.join(EFFECTS[effect].param_names())}"
        )
    # The model's world: the scenario's plant with its extra effects off and the model's own parameters.
    off = {n: {"enabled": False} for n in EFFECTS}
    model_sc = _with_plant(sc, {"effects": off})
    if effect == "cogging":
        # The seed's cogging law lives in the parameters: the rig has it, the model's world does not.
        model_sc = _with_plant(model_sc, {"params": {"xi0": 0.0}})
        rig_sc = _with_plant(
            sc, {"effects": off, "params": {"xi0": eff.get("xi0", 4.0), "ell": eff.get("ell", 3.6e-3)}}
        )
    else:
        rig_sc = _with_plant(
            sc,
            {
                "effects": {
                    **off,
                    effect: {
                        "enabled": True,
                        **{kk: v for kk, v in eff.items() if kk in EFFECTS[effect].param_names()},
                    },
                }
            },
        )
    ctrl_params = sc.controller_model_params()
    if effect == "cogging":
        # The cogging under study is what the controller's model lacks, in all three runs.
        ctrl_params = ctrl_params.without_cogging()
        model_sc = _with(model_sc, {"controller_params": {"xi0": 0.0}})
        rig_sc = _with(rig_sc, {"controller_params": {"xi0": 0.0}})
    spec = library_specs()[effect]
    p_base = ctrl_params.without_cogging().vector() if effect == "cogging" else ctrl_params.vector()
    if fitted is None:
        gen = generate_dataset(
            rig_sc.plant_config(),
            rig_sc.plant_params(),
            seed=sc.seed,
            settings=fit_settings or GeneratorSettings(n_runs=4, run_duration=8.0),
            controller_params=ctrl_params.without_cogging(),
            progress=progress,
        )
        diag = diagnose(
            gen.dataset,
            params=Params.from_vector(p_base),
            settings=DiagnoseSettings(candidates=[effect], simulate=False),
        )
        sc_e = next(s for s in diag.scores if s.name == effect)
        fitted = {kk: v for kk, v in sc_e.params.items()}
    w, p_aug = _spec_values(spec, fitted, p_base)
    results = {}
    logs = {}
    for run, scn, comp in (("model", model_sc, False), ("rig", rig_sc, False), ("compensated", rig_sc, True)):
        ctrl = build_controller(scn)
        if comp:
            lag = float(fitted.get("effective_delay_s", 0.0)) if spec.lag else 0.0
            ctrl = EffectCompensation(ctrl, spec, w, ctrl_params, p_aug, lag_delay=lag)
        res = run_scenario(scn, controller=ctrl, progress=progress, figures=False)
        results[run] = res.metrics.to_dict()
        logs[run] = {c: res.columns[c] for c in ("t", "g_true", "g_ref", "d_true", "d_ref")}
    return ClosedLoopView(sc.name, effect, eff, fitted, results, logs)


# ------------------------------------------------------- closed loop from a report
#: Logged signals compared between the rig log and the simulations, with their plot scale and unit.
COMPARED: dict[str, tuple[float, str]] = {"g": (1e6, "um"), "d": (1e6, "um"), "i_q": (1.0, "A"), "i_d": (1.0, "A")}


@dataclass
class ReportClosedLoop:
    """A closed-loop rig log against simulations of the diagnosis's baseline and augmented model.

    Attributes
    ----------
    scenario : str
        Scenario name.
    report : str
        The ``report.json`` used.
    verdict : str
        The report's verdict.
    model : str
        The augmented model's label (the verdict's effects with their fitted laws).
    rms : dict
        ``{"baseline" | "augmented": {signal: rms of (simulation - rig)}}`` over the run,
        signals :data:`COMPARED` in SI units (m, A).
    shrink : dict
        ``{signal: 1 - rms_augmented / rms_baseline}``: how far the closed-loop gap shrinks.
    metrics : dict
        ``{run: metrics dict}`` of the rig and the two simulations.
    """

    scenario: str
    report: str
    verdict: str
    model: str
    rms: dict[str, dict[str, float]]
    shrink: dict[str, float]
    metrics: dict[str, dict]
    logs: dict[str, dict] = field(default_factory=dict)

    def table(self) -> str:
        """Text table: rms difference to the rig log per signal, and the shrink."""
        head = f"{'signal':<8} {'baseline - rig':>16} {'augmented - rig':>16} {'shrink':>8}"
        lines = [
            f"scenario {self.scenario}: rig log vs simulations of {self.report} (verdict {self.verdict}, "
            f"model {self.model})",
            head,
            "-" * len(head),
        ]
        for sig, (scale, unit) in COMPARED.items():
            b, a = self.rms["baseline"].get(sig), self.rms["augmented"].get(sig)
            sh = self.shrink.get(sig, math.nan)
            lines.append(f"{sig:<8} {b * scale:12.3f} {unit:<3} {a * scale:12.3f} {unit:<3} {sh:8.0%}")
        return "\n".join(lines)

    def save(self, out_dir: str | os.PathLike) -> Path:
        """Write ``closed_loop.json``, ``closed_loop.md`` and ``closed_loop.png``."""
        doc = {
            **_pick(self, "scenario", "report", "verdict", "model"),
            "rms_vs_rig": self.rms,
            **_pick(self, "shrink", "metrics"),
        }
        return _save_view(out_dir, doc, "Closed loop: rig log vs the diagnosis's models", self.table(), self.figure)

    def figure(self) -> Figure | None:
        """Each compared signal of both simulations minus the rig log (None without logs)."""
        if self.logs:
            import matplotlib.pyplot as plt

            fig, ax = plt.subplots(len(COMPARED), 1, figsize=(10, 8), sharex=True)
            rig = self.logs["rig"]
            for j, (sig, (scale, unit)) in enumerate(COMPARED.items()):
                for run in ("baseline", "augmented"):
                    cols = self.logs[run]
                    n = min(len(cols["t"]), len(rig["t"]))
                    ax[j].plot(cols["t"][:n], (cols[sig][:n] - rig[sig][:n]) * scale, lw=0.8, label=f"{run} - rig")
                ax[j].set_ylabel(f"{sig} [{unit}]")
                ax[j].grid(True, alpha=0.3)
            ax[0].legend(fontsize=8)
            ax[-1].set_xlabel("time t [s]")
            ax[0].set_title(f"{self.scenario}: simulation minus rig log")
            fig.tight_layout()
            return fig
        return None


def closed_loop_from_report(
    scenario, report: str | os.PathLike, seed: int | None = None, progress: bool = False
) -> ReportClosedLoop:
    """Run ``scenario`` on its plant (the rig log) and on the report's baseline and augmented model files.

    Uses only what the diagnosis wrote: its verdict and the ``baseline.yaml`` /
    ``model.yaml`` plant files beside ``report.json`` (the fitted laws of the
    verdict's effects), never a named effect. The three runs share the
    scenario's controller, references and seed.

    Parameters
    ----------
    scenario : Scenario, dict or path
        The closed-loop scenario; its plant stands for the rig.
    report : path
        A diagnosis ``report.json``.
    seed : int, optional
        Replace the scenario's seed.
    progress : bool
        Progress bars.
    """
    path = Path(report)
    try:
        doc = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise UserError(f"{path}: cannot read the diagnosis report: {err}") from None
    if not isinstance(doc, dict) or "verdict" not in doc:
        raise UserError(f"{path}: verdict: missing; not a diagnosis report")
    files = {}
    for run, name in (("baseline", "baseline.yaml"), ("augmented", "model.yaml")):
        f = path.parent / name
        if not f.is_file():
            raise UserError(f"{path}: {name}: missing beside the report (maglev diagnose writes it with the report)")
        files[run] = str(f.resolve())
    sc = _as_scenario(scenario).with_seed(seed)
    cons = doc.get("consequences") or {}
    runs = {"rig": sc}
    for run, f in files.items():
        data = json.loads(json.dumps(sc.resolved(), default=_jsonable))
        data["plant"] = {"file": f}
        runs[run] = scenario_from_dict(data, source=f"{sc.source} on {f}", root_dir=sc.root_dir)
    from ..codegen.loop_c import run_scenario_on  # the loop choice (codegen is heavy to import)

    metrics, logs = {}, {}
    for run, scn in runs.items():
        res = run_scenario_on(scn, progress=progress)  # the compiled loop where it can run (same maths)
        metrics[run] = res.metrics.to_dict()
        logs[run] = {c: np.asarray(res.columns[c], float) for c in ("t", *COMPARED)}
    rig = logs["rig"]
    rms: dict[str, dict[str, float]] = {}
    for run in ("baseline", "augmented"):
        n = min(len(logs[run]["t"]), len(rig["t"]))
        rms[run] = {s: float(np.sqrt(np.mean((logs[run][s][:n] - rig[s][:n]) ** 2))) for s in COMPARED}
    shrink = {
        s: (1.0 - rms["augmented"][s] / rms["baseline"][s]) if rms["baseline"][s] > 0 else math.nan for s in COMPARED
    }
    return ReportClosedLoop(
        sc.name, str(path), str(doc["verdict"]), str(cons.get("model", doc.get("final_model", "?"))), rms, shrink,
        metrics, logs,
    )  # fmt: skip


def _with(sc, over: dict):
    """Scenario copy with ``over`` merged into its resolved settings (nested mappings merge)."""
    data = json.loads(json.dumps(sc.resolved(), default=_jsonable))
    return scenario_from_dict(deep_merge(data, over), source=sc.source, root_dir=sc.root_dir)


def _with_plant(sc, over: dict):
    """Scenario copy with plant-file keys merged into its ``plant`` block."""
    return _with(sc, {"plant": over})


__all__ = [
    "COMPARED",
    "ClosedLoopView",
    "EffectCompensation",
    "ReportClosedLoop",
    "closed_loop_from_report",
    "closed_loop_view",
    "fitted_from_report",
]
