"""Tests of :mod:`slam.mapping`."""
