"""Labeled goals: pIRS (Algorithms 1-2) over the single-block roadmap of the work cell."""
