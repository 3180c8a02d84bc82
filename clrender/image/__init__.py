"""Images on the host: reading and writing files (files), convolution filters, display and charts (plot)."""
