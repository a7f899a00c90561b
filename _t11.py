import numpy as np, clarabel, pickle
from tests.test_nmpc_qp import run_switch, qp_of
from controllers.nmpc import NMPCSettings
from controllers.nmpc.exact_qp import solve_exact, kkt_residuals, _conic_data, ExactSolution, QPData
from controllers.nmpc.layout import NU
rec, plant = run_switch(NMPCSettings(reference="plan"))
qps=[qp_of(rec.fns,c) for c in rec.calls]
pickle.dump(qps, open("/tmp/qp_switch.pkl","wb"))
def solve(qp, tol, scale, eq=True, maxit=400):
    P,c,A,b,n=_conic_data(qp)
    cones=[clarabel.NonnegativeConeT(3*qp.ng)]+[clarabel.SecondOrderConeT(3)]*n
    st=clarabel.DefaultSettings(); st.verbose=False
    st.tol_gap_abs=st.tol_gap_rel=st.tol_feas=st.tol_ktratio=tol; st.max_iter=maxit; st.equilibrate_enable=eq
    sol=clarabel.DefaultSolver(P*scale,c*scale,A,b,cones,st).solve()
    x=np.asarray(sol.x); v=x[:qp.nv]
    return ExactSolution(v, x[qp.nv:], np.asarray(sol.z)/scale, qp.objective(v), str(sol.status), sol.iterations)
for tol,scale,eq in [(1e-9,1,True),(1e-12,1,True),(1e-9,1e-3,True),(1e-12,1e-3,True),(1e-10,1,False)]:
    ex=[solve(q,tol,scale,eq) for q in qps]
    r=[kkt_residuals(q,e) for q,e in zip(qps,ex)]
    print(tol,scale,eq,{k: max(x[k] for x in r) for k in r[0]}, set(e.status for e in ex), max(e.iterations for e in ex))
