"""Fitting as a user asks for it: ``driver.fit`` with physical effects switched on (their
pre-check, shear moduli, plausibility), the uncertainty budget, and the likely causes of
a poor fit (residual signatures)."""
