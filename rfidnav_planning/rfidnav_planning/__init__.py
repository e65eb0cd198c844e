"""Planners and navigators of rfidnav: the partition path planner and navigator (paper 000)."""
