"""rosbag2 MCAP bags of rfidnav: the recorder and player nodes, and reading and writing bags."""
