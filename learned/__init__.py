"""Learned continual hand-eye calibration (torch): models, losses, strategies.

Not implemented yet: this package arrives with the learned-module issue. It
will never import :mod:`sim` or :mod:`classic`; it reads datasets and labels.
"""
