"""Contact of the rod with static convex primitives: IPC barrier, lagged smoothed friction, conservative CCD."""
