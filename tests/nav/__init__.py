"""Tests of :mod:`nav`."""
