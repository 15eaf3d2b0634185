"""The robot's own model, one home for the sim, the arm node and the planner: the UR10e's
kinematics and limits, and the Robotiq 2F-85's geometry and knuckle joint. Pure numpy."""
