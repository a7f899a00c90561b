import pickle, sys, numpy as np
from controllers.nmpc import NMPCSettings, step_functions
from maglev_ocp.fastcall import BufferedFunction
data = pickle.load(open("/tmp/qp_recs.pkl","rb"))
for arg in sys.argv[1:]:
    s = NMPCSettings(**eval(arg))
    f = BufferedFunction(step_functions(s,"preview")[1])
    r=[f(*d[4]) for d in data]
    it=np.array([x[2][3] for x in r]); e=np.array([np.max(np.abs(x[0].ravel()-(d[2].ubar[:2]+d[3][:2]))) for x,d in zip(r,data)])
    print(arg, "it mean %.1f p99 %.0f max %.0f | err med %.1e p99 %.1e max %.1e" % (it.mean(), np.percentile(it,99), it.max(), np.median(e), np.percentile(e,99), e.max()), flush=True)
