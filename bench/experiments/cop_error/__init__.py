"""The CoP-error experiment: why the simulated CoP leaves the analytic ZMP on flat ground
(simulated flat walks, landing timing, the command's missing terms) and its report."""
