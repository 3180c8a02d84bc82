"""clrender: a Whitted ray tracer, convolution filters and image splatting on OpenCL."""
__version__ = "0.1.0"
