"""Running a scene: :func:`nld.run.simulate.simulate` (tables of states and joint forces over time)
and the named hard regression cases (hard_cases)."""
