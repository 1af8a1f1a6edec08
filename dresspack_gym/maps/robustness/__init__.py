"""Robustness mapping of cable configurations (thesis §4.2, Algorithm 1) with an N-path extension."""
