"""Tests of :mod:`slam.kinds.attitude`."""
