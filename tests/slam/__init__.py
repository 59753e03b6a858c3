"""Tests of :mod:`slam`: the registry, the campaign runner, the command line, the renderer,
scoring, golden summaries and a plug-in kind."""
