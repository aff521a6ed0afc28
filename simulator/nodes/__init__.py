"""The simulated ROS nodes, one class per node (or per group of nodes that always go together). See ../README.md."""
