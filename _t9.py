import numpy as np
from tests.test_nmpc_qp import run_switch, qp_of
from controllers.nmpc import NMPCSettings
from controllers.nmpc.exact_qp import solve_exact, kkt_residuals
rec, plant = run_switch(NMPCSettings(reference="plan"))
qps=[qp_of(rec.fns,c) for c in rec.calls]
for tol in ():
    ex=[solve_exact(q, tol=tol) for q in qps]
    r=[kkt_residuals(q,e) for q,e in zip(qps,ex)]
    print(tol, {n: max(x[n] for x in r) for n in r[0]}, set(e.status for e in ex))
ex=[solve_exact(q, tol=1e-9) for q in qps]
r=[kkt_residuals(q,e) for q,e in zip(qps,ex)]
i=int(np.argmax([x["complementarity"] for x in r]))
q=qps[i]; e=ex[i]
print(i, e.status, e.iterations, e.objective, np.abs(q.H).max(), np.abs(q.q).max(), q.disk_violation(e.v), e.s, q.gap_violation(e.v))
from controllers.nmpc.exact_qp import _conic_data
P,c,A,b,n=_conic_data(q); x=np.concatenate([e.v,e.s]); sl=b-A@x; z=e.z
m=3*q.ng; print("nonneg comp", np.abs(sl[:m]*z[:m]).max(), "soc", max(abs(sl[m+3*k:m+3*k+3]@z[m+3*k:m+3*k+3]) for k in range(n)))
print("tour", [ (k, sl[m+3*k:m+3*k+3], z[m+3*k:m+3*k+3]) for k in range(n) if abs(sl[m+3*k:m+3*k+3]@z[m+3*k:m+3*k+3])>1e-7])
