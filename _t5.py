import pickle, sys, numpy as np, time
from benchmarks.qp_accuracy import evaluate
from controllers.nmpc import NMPCSettings, step_functions
from maglev_ocp.fastcall import BufferedFunction
acc, recs = evaluate("base", {"iterations":20}, scenarios=("tour_nmpc","push_g_nmpc","traverse_20mm_nmpc","push_d_nmpc","gap_steps_nmpc"))
data = [(n,i,r[2],r[3].v,r[4][:4]) for r in recs for (n,i) in [r[:2]]]
pickle.dump(data, open("/tmp/qp_recs.pkl","wb"))
print(acc.u_err_A, acc.worst)
