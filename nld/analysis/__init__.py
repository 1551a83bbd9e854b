"""Analyses on any system (a scene's SceneSystem or a user ODE/map): Poincare sections (poincare),
bifurcation diagrams (bifurcation), Lyapunov exponents (lyapunov), contact-force spectra (spectrum),
chaos maps (chaos_map), the 0-1 test (zero_one), located per-revolution extrema (extrema) and the mean of per-revolution
peaks with an interval that holds across realisations (peaks).
No argparse here: the command line is nld.cli."""
