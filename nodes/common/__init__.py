"""Plumbing shared by every node: parameters, QoS, the ``main()`` idiom, paths, test harness."""
