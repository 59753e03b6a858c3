"""Tests of :mod:`slam.kinds.drone`."""
