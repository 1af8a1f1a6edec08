"""Stations with several robots: shared welds, timed schedules on one clock, robot-robot coordination, replay."""
