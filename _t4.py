"""C step timing for settings overrides: python -m _t4 "{...}" """
import sys, time, numpy as np
from benchmarks.qp_accuracy import load_scenario, RecordingEvaluators
from maglev_ocp.codegen.backend import c_evaluators
from controllers.nmpc import NMPC
from maglev_ocp.runner import run_scenario
from maglev_ocp.codegen.bench import realtime_priority
over = eval(sys.argv[1]) if len(sys.argv) > 1 else {}
sc = load_scenario(sys.argv[2] if len(sys.argv) > 2 else "tour_nmpc", over)
t=time.time()
ev = c_evaluators(progress=False)
ctrl = NMPC(sc.controller.settings, sc.controller_model_params(), evaluators=ev)
ctrl.prepare("preview")
print("build", time.time()-t)
ks=[]
class R:
    def __init__(s,c): s.c=c
    def __getattr__(s,a): return getattr(s.c,a)
    def reset(s,y,r): s.c.reset(y,r)
    def step(s,y,r):
        o=s.c.step(y,r); ks.append((o.stats["kernel_us"], o.stats["iters_to_tol"])); return o
with realtime_priority(True) as rt:
    res = run_scenario(sc, controller=R(ctrl), progress=False, figures=False)
k=np.array(ks[50:])
print("rt", rt, "passed", res.passed, "kernel us median %.1f p99 %.1f max %.1f" % (np.median(k[:,0]), np.percentile(k[:,0],99), k[:,0].max()), "iters med/max", np.median(k[:,1]), k[:,1].max())
