"""Reading and writing recorded robot data: ROS bags, dataset tables, and other robots' formats."""
