"""What no plan can beat: the goal layout's assembly order, certified lower bounds,
certificates that a scene has no plan, and the exact search for small scenes."""
