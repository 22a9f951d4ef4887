"""Simulator (Pinocchio UR robot, pyrender scenes) and labelled datasets.

Not implemented yet: this package arrives with the simulator issue. It is the
only place that sees OpenGL camera poses.
"""
