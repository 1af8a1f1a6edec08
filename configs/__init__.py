"""Shipped configuration files (robots, dresspacks, stations, grids, training): package data of dresspack_gym."""
