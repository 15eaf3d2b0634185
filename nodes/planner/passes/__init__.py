"""Passes over a finished plan (shortcut, rebuffer, re-insertion, necessity) and the anytime
restarts that keep the shortest validated plan."""
