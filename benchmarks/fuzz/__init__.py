"""Fuzz harness for the ``slam`` command line.

:mod:`benchmarks.fuzz.mutate` makes deterministic, seeded bad inputs from the bundled
world files and from a truncated GTSAM planar log; :mod:`benchmarks.fuzz.harness` runs
each one through ``slam run`` in a child process with a wall-time and memory limit and
classifies the outcome. ``python -m benchmarks.fuzz --help`` runs a whole campaign.
The project is treated as a black box: only its CLI is called, and only the bundled
``worlds/*.toml`` (and the data files they name), GTSAM's example log and the kinds' world
schema tables (:mod:`benchmarks.fuzz.schemas`: which keys are σ, rates, durations) are
read. ``python -m benchmarks.fuzz`` documents the commands of a full re-run.
"""
