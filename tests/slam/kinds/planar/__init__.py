"""Tests of :mod:`slam.kinds.planar`."""
