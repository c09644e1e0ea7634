"""Studies built on the solvers: the paper's printed data, work-precision, the critical-step map."""
