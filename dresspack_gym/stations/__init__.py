"""Stations: configuration, the compiled MuJoCo model, checks, collision and motion validity, weld tasks and
sampling, offscreen rendering."""
