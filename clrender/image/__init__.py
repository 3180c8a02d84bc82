"""Images on the host: reading and writing files (files), convolution filters, display and charts (plot)."""


def __getattr__(name):  # submodules load on first use: clrender.image.X after a plain `import clrender`
    from .. import _submodule

    return _submodule(__name__, name)
