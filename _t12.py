import numpy as np, pickle
from controllers.nmpc.exact_qp import solve_exact, kkt_residuals
qps=pickle.load(open("/tmp/qp_switch.pkl","rb"))
ex=[solve_exact(q) for q in qps]; r=[kkt_residuals(q,e) for q,e in zip(qps,ex)]
print({k: max(x[k] for x in r) for k in r[0]}, set(e.status for e in ex))
