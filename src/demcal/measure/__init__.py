"""Angle of repose from photos and from simulated piles."""
