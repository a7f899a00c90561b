"""C code generation: generated Functions equal the Python controllers, the compiled C equals the Python backend.

The tests that compile need a C compiler and ``make``; without them they are
skipped with that reason (never silently). Builds go through the content-hash
cache (``$MAGLEV_CODEGEN_CACHE`` or ``~/.cache/maglev-ocp/codegen``), so only the
first run on a machine pays the compilation. The default-run tests compile the
NMPC with ``-O0`` (:data:`TEST_CFLAGS`: about 30 s on 2 loaded cores instead of
80 s at the shipped ``-O1``; without -ffast-math both give the same IEEE results);
the slow tour test uses the shipped flags.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from maglev_ocp import constants as k
from maglev_ocp.blocks import Reference
from maglev_ocp.codegen import KINDS, controller_codes, generate_controllers
from maglev_ocp.codegen.build import HARNESS, find_compiler
from maglev_ocp.fastcall import BufferedFunction
from maglev_ocp.observers import HighGainObserver, ObserverSettings
from maglev_ocp.params import NOMINAL
from maglev_ocp.scenario import StartSpec

#: The scenarios' default hover at the start, before the first target [s].
HOVER = StartSpec().hover

CC = find_compiler()
needs_cc = pytest.mark.skipif(
    CC is None or shutil.which("make") is None,
    reason="no C compiler (cc/gcc/clang, or $CC) or no make on the PATH: the generated C cannot be built here",
)
I_TOL = 1e-6  # A: C and Python currents must agree to this at every step
TEST_CFLAGS = "-O0 -fno-math-errno"  # correctness only: fastest to compile

#: Short closed loop: hover, then a diagonal move and hold.
SCENARIO = {
    "name": "codegen_check",
    "seed": 5,
    "controller": {"type": "nmpc"},
    "plant": {"profile": "default"},
    "targets": [{"g": 0.020, "d": 0.000, "hold": 0.06}, {"g": 0.018, "d": 0.012, "hold": 0.16}],
}


def _scenario(ctype: str, shaping: str = "trajectory", **controller) -> dict:
    """The short scenario for ``ctype``; ``shaping: step`` puts the NMPC in its internal-planner mode, whose
    inputs (targets) a rig log holds exactly; in preview mode the NMPC reads the plan's point accelerations
    ahead, which a log does not hold (it stores their mean over each period), so its harness replay is exact
    only in plan mode."""
    return {
        **SCENARIO,
        "name": f"codegen_{ctype}",
        "controller": {"type": ctype, **controller},
        "reference": {"shaping": shaping},
    }


# ----------------------------------------------------------------------------- no compiler needed
@pytest.mark.parametrize("disturbance", [True, False])
def test_observer_function_matches_python_observer(disturbance):
    from maglev_ocp.codegen.observer_fn import observer_step_function

    s = ObserverSettings(eps=3e-3, disturbance=disturbance)
    params = NOMINAL.scaled({"C2": 1.03})
    py = HighGainObserver(params, s)
    fn = BufferedFunction(observer_step_function(s))
    rng = np.random.default_rng(1)
    py.reset([0.019, 0.01])
    x, d = py.x_hat.copy(), np.zeros(2)
    for _ in range(400):
        y = np.array([0.019, 0.01]) + rng.normal(0, 2e-5, 2)
        u = rng.normal([0.0, -1.0], 2.0)
        xa = py.step(y, u)
        x, d = fn(x, d, u, y, params.vector())
        assert np.max(np.abs(xa - x)) <= 1e-12
        assert np.max(np.abs(py.disturbance - d)) <= 1e-12
    assert np.all(np.isfinite(x)) and abs(x[0] - 0.019) < 1e-3  # a meaningful run, not a blow-up


def test_fl_step_function_matches_python_controller():
    from maglev_ocp.codegen.fl_fn import fl_functions
    from maglev_ocp.controllers.fl import FeedbackLinearization, FLSettings
    from maglev_ocp.plant import Plant, PlantConfig

    s = FLSettings(integral=True, omega_g=60.0)
    params = NOMINAL
    py = FeedbackLinearization(s, params)
    init, step = (BufferedFunction(f) for f in fl_functions(s))
    plant = Plant(PlantConfig.from_profile("default"), params=NOMINAL, seed=2)
    y = plant.reset()
    py.reset(y, Reference(0.02, 0.0))
    (st,) = init(y.y)
    for i in range(300):
        ref = Reference(0.02, 0.0) if i < 50 else Reference(0.017, -0.01)
        out = py.step(y, ref)
        r = [ref.g, ref.g_dot, ref.g_ddot, ref.d, ref.d_dot, ref.d_ddot]
        u, st, xh, *_ = step(st, y.y, r, params.vector(), s.gains())
        assert np.max(np.abs(u - out.u)) <= 1e-12
        assert np.max(np.abs(xh - out.x_hat)) <= 1e-12
        y = plant.step(out.u)
    assert abs(y.x_true[0] - 0.017) < 1e-3  # it did move


def test_codegen_of_all_controllers_is_documented_and_malloc_free():
    src = generate_controllers(KINDS)
    files = src.files
    for fn in ("nmpc_init", "nmpc_step", "fl_init", "fl_step", "observer_step"):
        c = files[f"{fn}.c"]
        assert f"int {fn}(const casadi_real** arg" in c
        assert "malloc" not in c and "calloc" not in c
        assert f"#define {fn.upper()}_SZ_W " in files["maglev_controller.h"]
    hdr = files["maglev_controller.h"]
    # every packed state is laid out completely: the offsets of its last piece plus its size = the total size
    codes = {c.kind: c for c in controller_codes(KINDS)}
    for code in codes.values():
        for unit in code.units:
            for d, ports in (("IN", unit.inputs), ("OUT", unit.outputs)):
                for p in ports:
                    base = f"{unit.name}_{d}_{p.name}".upper()
                    assert re.search(rf"#define {base}_SIZE {p.size}\b", hdr), base
                    if p.pieces:
                        last = p.pieces[-1]
                        m = re.search(rf"#define {base}_{last.name.upper()}_OFFSET (\d+)", hdr)
                        assert m and int(m.group(1)) + last.size == p.size, base
    assert "[m/s^2]" in hdr and "[A]" in hdr  # units from maglev_ocp.signals
    defined = re.findall(r"^#define (\w+)", hdr, re.M)
    assert len(defined) == len(set(defined)), "a macro is defined twice"
    n = codes["nmpc"].defines["HORIZON"]
    assert n >= 20 and f"#define NMPC_STATE_SIZE {codes['nmpc'].step.inputs[0].size}" in hdr
    mk = files["Makefile"]
    assert (
        all(f"{fn}.c" in mk for fn in src.functions)
        and "CFLAGS ?=" in mk
        and "-ffast-math" not in mk.split("CFLAGS ?=")[1].splitlines()[0]
    )
    man = json.loads(files["manifest.json"])
    assert set(man["controllers"]) == set(KINDS) and len(man["sources"]) == len(src.functions)
    assert src.digest == generate_controllers(KINDS).digest  # deterministic: same design, same files


def test_cli_codegen_needs_out_and_never_writes_cwd(tmp_path, monkeypatch, capsys):
    from maglev_ocp.cli import main

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as e:
        main(["codegen"])
    assert e.value.code == 2
    assert main(["codegen", "--out", "."]) == 2
    assert "current directory" in capsys.readouterr().err
    assert main(["codegen", "--out", "x", "--controllers", "fl,mpc"]) == 2
    assert "--controllers" in capsys.readouterr().err
    assert main(["codegen", "--out", "x", "--params", "missing.yaml"]) == 2
    assert "missing.yaml" in capsys.readouterr().err
    assert main(["bench", "--controllers", "fl,foo"]) == 2
    assert "--controllers: foo" in capsys.readouterr().err
    assert main(["bench", "--scenario", "missing.yaml"]) == 2
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- compiled
@pytest.fixture(scope="module")
def nmpc_runs():
    """The short scenario with NMPC (internal planner) on the Python and on the C backend (compiled, cached)."""
    from maglev_ocp.codegen.backend import build_c_controller
    from maglev_ocp.runner import run_scenario
    from maglev_ocp.scenario import scenario_from_dict

    sc = scenario_from_dict(_scenario("nmpc", shaping="step"))
    py = run_scenario(sc, progress=False, figures=False)
    ctrl = build_c_controller(
        "nmpc", sc.controller.settings, sc.controller_model_params(), cflags=TEST_CFLAGS, progress=False
    )
    c = run_scenario(sc, controller=ctrl, progress=False, figures=False)
    return py, c, ctrl


@needs_cc
def test_nmpc_c_backend_reproduces_python_closed_loop(nmpc_runs):
    py, c, ctrl = nmpc_runs
    assert ctrl.backend == "c" and list(ctrl.evaluators.builds) == ["plan"]  # really the compiled library
    n = len(py.columns["t"])
    assert n == round((HOVER + 0.22) / k.Ts) and len(c.columns["t"]) == n
    for col in ("i_q", "i_d"):
        assert np.max(np.abs(py.columns[col] - c.columns[col])) <= I_TOL
    assert np.max(np.abs(py.columns["g_hat"] - c.columns["g_hat"])) <= 1e-9
    assert py.metrics.all_settled and c.metrics.all_settled
    assert np.max(np.hypot(c.columns["i_q"], c.columns["i_d"])) <= k.i_amp_max + 1e-9


@needs_cc
def test_nmpc_harness_built_with_make_reproduces_logged_run(nmpc_runs, tmp_path):
    py, _, ctrl = nmpc_runs
    build = next(iter(ctrl.evaluators.builds.values()))
    folder = build.folder
    r = subprocess.run(["make", "-C", str(folder), HARNESS], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    py.save(tmp_path / "run", figures=False)
    out = tmp_path / "c.csv"
    r = subprocess.run(
        [str(folder / HARNESS), "nmpc", str(tmp_path / "run" / "log.csv"), "-o", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    assert "wall median" in r.stderr and "cpu median" in r.stderr
    got = np.genfromtxt(out, delimiter=",", names=True)
    assert len(got) == len(py.columns["t"])
    for col in ("i_q", "i_d"):
        assert np.max(np.abs(got[col] - py.columns[col])) <= I_TOL


@needs_cc
def test_fl_and_observer_compiled_and_harness(tmp_path):
    from maglev_ocp.cli import main
    from maglev_ocp.codegen.backend import CompiledObserver, build_c_controller
    from maglev_ocp.controllers.fl import FLSettings
    from maglev_ocp.runner import run_scenario
    from maglev_ocp.scenario import scenario_from_dict

    sc = scenario_from_dict(_scenario("fl", integral=True))
    py = run_scenario(sc, progress=False, figures=False)
    ctrl = build_c_controller(
        "fl", sc.controller.settings, sc.controller_model_params(), cflags=TEST_CFLAGS, progress=False
    )
    c = run_scenario(sc, controller=ctrl, progress=False, figures=False)
    for col in ("i_q", "i_d"):
        assert np.max(np.abs(py.columns[col] - c.columns[col])) <= I_TOL
    assert py.metrics.all_settled

    # maglev codegen --make writes a folder whose harness replays the logged run
    fl_s: FLSettings = sc.controller.settings
    scen = tmp_path / "sc.yaml"
    scen.write_text(json.dumps(_scenario("fl", integral=True)))
    out = tmp_path / "gen"
    assert main(["codegen", "--out", str(out), "--scenario", str(scen), "--controllers", "fl,observer", "--make"]) == 0
    assert (out / "maglev_controller.h").exists() and (out / HARNESS).exists()
    py.save(tmp_path / "run", figures=False)
    log = tmp_path / "run" / "log.csv"
    r = subprocess.run(
        [str(out / HARNESS), "fl", str(log), "-o", str(tmp_path / "fl.csv")], capture_output=True, text=True, timeout=60
    )
    assert r.returncode == 0, r.stderr
    got = np.genfromtxt(tmp_path / "fl.csv", delimiter=",", names=True)
    for col in ("i_q", "i_d"):
        assert np.max(np.abs(got[col] - py.columns[col])) <= I_TOL
    # the observer alone replays the log's own currents, as the stepped Python observer does
    r = subprocess.run(
        [str(out / HARNESS), "observer", str(log), "-o", str(tmp_path / "obs.csv")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert r.returncode == 0, r.stderr
    got = np.genfromtxt(tmp_path / "obs.csv", delimiter=",", names=True)
    y = np.column_stack([py.columns["g"], py.columns["d"]])
    u = np.column_stack([py.columns["i_q"], py.columns["i_d"]])
    obs = HighGainObserver(
        sc.controller_model_params(), ObserverSettings(eps=fl_s.observer_eps, disturbance=fl_s.disturbance)
    )
    obs.reset(y[0])
    ref = np.vstack([obs.x_hat, *(obs.step(y[i], u[i - 1]) for i in range(1, len(y)))])
    est = np.column_stack([got["g_hat"], got["g_dot_hat"], got["d_hat"], got["d_dot_hat"]])
    assert np.max(np.abs(est - ref)) <= 1e-12
    # a CSV with a missing column is refused with the file and the column named
    bad = tmp_path / "bad.csv"
    bad.write_text("t,g,d,i_q\n0,0.02,0,0\n")
    r = subprocess.run([str(out / HARNESS), "fl", str(bad)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "missing column 'i_d'" in r.stderr and "bad.csv" in r.stderr
    # the compiled observer object equals the Python one
    ob_c = CompiledObserver(NOMINAL, cflags=TEST_CFLAGS, progress=False)
    ob_py = HighGainObserver(NOMINAL, ObserverSettings())
    ob_c.reset(y[0])
    ob_py.reset(y[0])
    for i in range(1, 100):
        assert np.max(np.abs(ob_c.step(y[i], u[i - 1]) - ob_py.step(y[i], u[i - 1]))) <= 1e-12


@needs_cc
def test_bench_reports_every_controller_and_backend(tmp_path):
    from maglev_ocp.codegen.bench import run_bench

    sc = {**_scenario("fl"), "targets": [{"g": 0.02, "d": 0.0, "hold": 0.1}]}
    res = run_bench(sc, controllers=("fl", "pid"), warmup=10, cflags=TEST_CFLAGS, progress=False)
    d = res.to_dict()
    assert set(d) == {"fl", "pid"}
    for ct in ("fl", "pid"):
        for b in ("python", "c"):
            e = d[ct][b]
            assert e["n"] == round((0.1 + HOVER) / k.Ts) - 10 and 0 < e["median_us"] <= e["p99_us"] <= e["max_us"]
        assert 0 < d[ct]["c"]["kernel_median_us"] <= d[ct]["c"]["median_us"]
    assert 0 < d["fl"]["c"]["kernel_cpu_median_us"] <= d["fl"]["c"]["kernel_cpu_max_us"]
    assert "controller" in res.table() and res.save(tmp_path / "b.json").exists()


def test_runner_builds_backend_c_through_the_registered_evaluators():
    """``backend: c`` in a scenario: the runner (below codegen) gets the builder maglev_ocp.codegen registered,
    and the NMPC it returns is the Python class with the compiled evaluators injected (one C path)."""
    from maglev_ocp.codegen.backend import CEvaluators, build_c_controller
    from maglev_ocp.controllers.nmpc import NMPC
    from maglev_ocp.runner import CONTROLLER_BACKENDS, build_controller
    from maglev_ocp.scenario import scenario_from_dict

    assert CONTROLLER_BACKENDS["c"] is build_c_controller
    sc = scenario_from_dict({**_scenario("nmpc"), "controller": {"type": "nmpc", "backend": "c"}})
    ctrl = build_controller(sc)
    assert type(ctrl) is NMPC and isinstance(ctrl.evaluators, CEvaluators) and ctrl.backend == "c"
    py = build_controller(scenario_from_dict(_scenario("nmpc")))
    assert type(py) is NMPC and py.backend == "python"


@needs_cc
def test_pid_backend_c_is_the_compiled_pid():
    """``backend: c`` of the PID: its whole step compiled (law, observer, schedule)."""
    from maglev_ocp.codegen.backend import CompiledPID, build_c_controller
    from maglev_ocp.controllers.pid import PIDController, PIDSettings
    from maglev_ocp.errors import UserError

    ctrl = build_c_controller("pid", PIDSettings(omega_g=70.0), NOMINAL, cflags=TEST_CFLAGS, progress=False)
    assert type(ctrl) is CompiledPID and isinstance(ctrl, PIDController) and ctrl.backend == "c"
    assert ctrl.settings.omega_g == 70.0
    with pytest.raises(UserError, match="not for 'lqr'"):
        build_c_controller("lqr", None, NOMINAL)


@pytest.mark.slow
@needs_cc
def test_shipped_nmpc_tour_on_the_c_backend_meets_tolerances_and_equals_python():
    """The envelope tour (preview mode) with the compiled NMPC at the shipped flags: every target held within
    0.1 mm, limits, no stops; and the currents equal the Python backend's at every step."""
    from pathlib import Path

    from maglev_ocp.codegen.backend import build_c_controller
    from maglev_ocp.runner import run_scenario
    from maglev_ocp.scenario import load_scenario

    sc = load_scenario(Path(__file__).resolve().parents[1] / "scenarios" / "tour_nmpc.yaml")
    ctrl = build_c_controller("nmpc", sc.controller.settings, sc.controller_model_params(), progress=False)
    res = run_scenario(sc, controller=ctrl, progress=False, figures=False)
    assert list(ctrl.evaluators.builds) == ["preview"]
    assert res.passed, res.table()
    assert res.metrics.stop_hits == 0 and res.metrics.all_settled
    py = run_scenario(sc, progress=False, figures=False)
    for col in ("i_q", "i_d"):
        assert np.max(np.abs(py.columns[col] - res.columns[col])) <= I_TOL
