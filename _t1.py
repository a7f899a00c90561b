import time, numpy as np
from benchmarks.qp_accuracy import *
from controllers.nmpc.exact_qp import kkt_residuals
t=time.time()
acc, recs = evaluate("fixed20", {}, scenarios=("gap_steps_nmpc",))
print(time.time()-t)
print(table([acc])); print(acc.worst)
k=[kkt_residuals(r[2], r[3]) for r in recs[::50]]
print({n: max(d[n] for d in k) for n in k[0]})
print(set(r[3].status for r in recs), max(r[3].iterations for r in recs))
