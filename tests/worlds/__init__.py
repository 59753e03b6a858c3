"""Tests of :mod:`worlds`: finding and reading world files, the schema engine."""
