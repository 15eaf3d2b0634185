"""The AprilTag detector: rendered overhead images -> block poses in ``world``.

Pure logic (no rclpy): ``tag_geometry`` (where a tag's corners sit on a block),
``camera_model`` (projection through the lens, rays, the calibration file), ``tags``
(finding 36h11 tags and refining their corners), ``estimate`` (corners -> block pose, by
method name), ``pipeline`` (one image -> a ``BlockSet``), ``warning_kinds`` (what it warns
about), ``sync`` (image / camera_info pairing, the newest complete frame handed on),
``calibration`` (camera pose from tags at known poses), ``synthetic`` (test images).
ROS adapter: ``node`` (``densepack-detector``); the camera pose calibration: ``nodes.calibration``.
"""
