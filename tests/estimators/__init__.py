"""Tests of :mod:`estimators`."""
