"""The densepack planner: pIRS over a single-block PRM mixing pick-and-place and pushes.

Subpackages by concept, each importing only the ones below it in this list:

* ``geometry``: what one action needs and hits (``obstacles``, ``transfer``, ``reach``),
  what a planning run shares (``context``), and the independent replay ``validator``.
* ``passes``: edits of a finished plan (``shortcut``, ``rebuffer``, ``reinsert``,
  ``necessity``) and the anytime restarts (``improve``).
* ``bounds``: the goal layout's order (``assembly``), certified lower bounds (``bound``,
  ``bound_starts``), certificates of no plan (``frozen``) and the exact search (``exact``).
* ``labeled``: pIRS (``pirs``) over the work cell (``cell_pirs``, ``roadmap``), and
  ``plan_labeled.plan_scene``, a labeled scene in, a validated plan out.
* ``unlabeled``: rearrangement pebble graphs, retrieval, the assignment baseline.

At the top: ``config`` (parameters), ``budget``, ``outcome`` (what every planner returns),
``dispatch`` (every goal kind), and the front ends ``node`` (ROS), ``cli`` (``densepack-plan``),
``draw`` and ``markers``. Nothing but ``node`` and ``markers`` imports rclpy.
"""
