"""Robots: configuration, kinematics (FK/IK), the MuJoCo body chain, URDF/MJCF import, checks, limits, time law,
joint restrictions."""
