"""The learned policy (MaskablePPO) behind the Planner interface."""
