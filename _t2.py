import numpy as np, time
from controllers.nmpc import NMPCSettings
from benchmarks.qp_accuracy import evaluate, table
import sys
over = eval(sys.argv[1]) if len(sys.argv)>1 else {}
sc = tuple(sys.argv[2].split(",")) if len(sys.argv)>2 else ("tour_nmpc",)
acc,_ = evaluate(str(over), over, scenarios=sc)
print(table([acc])); print(acc.worst, acc.passed)
