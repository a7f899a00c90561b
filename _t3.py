import time
from benchmarks.qp_accuracy import evaluate, table
acc,_ = evaluate("osqp", {"solver":"osqp"}, scenarios=("gap_steps_nmpc",))
print(table([acc])); print(acc.worst, acc.passed)
