"""Calibrating the overhead camera's pose (``densepack-calibrate``): from blocks at known poses,
or from the arm setting one block down at known placements with the executor's own scripts.
It stands above the detector and the executor, whose pieces it uses."""
