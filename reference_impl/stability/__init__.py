"""Section 6: the safe step, the critical-step search, its criteria and results."""
