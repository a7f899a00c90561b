import sys, time, numpy as np
from benchmarks.qp_accuracy import load_scenario, RecordingEvaluators
from maglev_ocp.codegen.backend import c_evaluators
from controllers.nmpc import NMPC, casadi_evaluators
from maglev_ocp.runner import run_scenario
from maglev_ocp.codegen.bench import realtime_priority
variants = [eval(a) for a in sys.argv[1:]]
sc = load_scenario("tour_nmpc", {})
rec = RecordingEvaluators()
run_scenario(sc, controller=NMPC(sc.controller.settings, sc.controller_model_params(), evaluators=rec), progress=False, figures=False)
calls = rec.calls
fns=[]
for v in variants:
    s = load_scenario("tour_nmpc", v).controller.settings
    ev = c_evaluators(progress=False)
    c = NMPC(s, sc.controller_model_params(), evaluators=ev); c.prepare("preview")
    fns.append(c.step_evaluator)
T = np.zeros((len(fns), len(calls)))
perf=time.perf_counter
with realtime_priority(True):
    for b0 in range(0, len(calls), 100):
        order = list(range(len(fns))); order = order if (b0//100)%2==0 else order[::-1]
        for j in order:
            f=fns[j]
            for i in range(b0, min(b0+100, len(calls))):
                c=calls[i]
                for a in range(4): f.args[a][:] = c[a]
                t0=perf(); f.call_raw(); T[j,i]=(perf()-t0)*1e6
for v,t in zip(variants,T):
    t=t[50:]; print(v, "median %.1f p99 %.1f p999 %.1f max %.1f" % (np.median(t), np.percentile(t,99), np.percentile(t,99.9), t.max()))
