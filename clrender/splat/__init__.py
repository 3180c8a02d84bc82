"""Image splatting: Gaussian splats fitted by gradient descent (gauss, fit) and Voronoi splats (voronoi)."""

INITS = ("uniform", "random", "gradient")  # where splats (fit.py) and sites (voronoi.py) start


def __getattr__(name):  # submodules load on first use: clrender.splat.X after a plain `import clrender`
    from .. import _submodule

    return _submodule(__name__, name)
