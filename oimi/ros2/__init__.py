"""oimi's ROS 2 edge without a ROS installation: DDS (Cyclone DDS) and rosbag2 (rosbags).

``oimi bridge`` runs the pipeline as a ROS 2 participant, ``oimi sim --ros2`` the
simulated robot as another, ``oimi export --ros2`` writes a session as a rosbag2 and
``oimi replay BAG/`` drives the pipeline over one. See ``docs/ros2.md``.
"""
