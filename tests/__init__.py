"""Tests of the workbench, one folder per package (``tests/<package>/...``).

The folders are packages so that test files in different folders may share a basename;
shared helpers are imported as ``tests.<module>`` (e.g. ``from tests.small_worlds import
small_world``).
"""
