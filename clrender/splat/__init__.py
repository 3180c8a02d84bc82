"""Image splatting: Gaussian splats fitted by gradient descent (gauss, fit) and Voronoi splats (voronoi)."""

INITS = ("uniform", "random", "gradient")  # where splats (fit.py) and sites (voronoi.py) start
