"""The scenario kinds, one folder each (planar, drone, attitude, recorded); the registry
that lists them is :mod:`slam.registry`."""
