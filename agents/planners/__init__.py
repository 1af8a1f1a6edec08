"""Single-robot planners: the Planner interface and budget, route generators, the composed, OMPL and wear-aware
planners, and their registry."""
