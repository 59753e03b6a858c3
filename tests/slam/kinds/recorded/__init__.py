"""Tests of :mod:`slam.kinds.recorded`."""
