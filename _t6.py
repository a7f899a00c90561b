import pickle, sys, numpy as np, time
from controllers.nmpc import NMPCSettings, step_functions
from maglev_ocp.fastcall import BufferedFunction
from benchmarks.qp_accuracy import _merge
data = pickle.load(open("/tmp/qp_recs.pkl","rb"))
for arg in sys.argv[1:]:
    over = eval(arg)
    base = {"type":"nmpc"}; _merge(base, over); base.pop("type")
    s = NMPCSettings(**base)
    init, step, b = step_functions(s, "preview")
    f = BufferedFunction(step)
    e=[]; it=[]
    for n,i,qp,v,ins in data:
        u, st, stats, xh = f(*ins)
        e.append(np.max(np.abs(u.ravel()-(qp.ubar[:2]+v[:2])))); it.append(stats[3])
    e=np.array(e); it=np.array(it)
    print(arg, "med %.1e p99 %.1e p999 %.1e max %.1e | it mean %.1f p99 %.0f max %.0f" % (np.median(e), np.percentile(e,99), np.percentile(e,99.9), e.max(), it.mean(), np.percentile(it,99), it.max()), flush=True)
