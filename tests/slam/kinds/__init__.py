"""Tests of :mod:`slam.kinds`: one folder per scenario kind."""
