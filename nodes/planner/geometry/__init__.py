"""Geometry of single actions and plans: collision masks, feasibility and cost of one
pick-and-place or push, the arm's reach, a planning run's context, the replay validator."""
