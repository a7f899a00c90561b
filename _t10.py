import numpy as np
from tests.test_nmpc_qp import run_switch, qp_of
from controllers.nmpc import NMPCSettings
from controllers.nmpc.exact_qp import solve_exact, kkt_residuals, _conic_data
rec, plant = run_switch(NMPCSettings(reference="plan"))
qps=[qp_of(rec.fns,c) for c in rec.calls]
ex=[solve_exact(q) for q in qps]
r=[kkt_residuals(q,e) for q,e in zip(qps,ex)]
i=int(np.argmax([x["complementarity"] for x in r])); q=qps[i]; e=ex[i]
P,c,A,b,n=_conic_data(q); x=np.concatenate([e.v,e.s]); sl=b-A@x; z=e.z; m=3*q.ng
print(i, e.status, r[i]); print("nonneg", sl[:m], z[:m])
for k in range(n):
    s_,z_=sl[m+3*k:m+3*k+3],z[m+3*k:m+3*k+3]
    if abs(s_@z_)>1e-9: print(k, s_, z_, s_@z_)
