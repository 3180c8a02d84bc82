"""Image splatting: Gaussian splats (gauss.py, fit.py) and nearest-site Voronoi splats (voronoi.py)."""
