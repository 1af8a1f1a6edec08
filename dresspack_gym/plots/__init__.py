"""Figures: measures over time, joint restriction zones, damage along the cable, station plans."""
