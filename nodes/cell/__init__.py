"""The whole cell, run: its node set launched from a cell file, a run driven from outside
(the goal sent on ``/rearrange``, the run watched, its report's figures), and the run's
timeline. Used by ``densepack-cell``, ``densepack-run`` and the cell benchmark."""
