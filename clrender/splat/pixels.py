"""The pixel values splatting accepts: finite, and small enough that sums of squares stay finite.

A NaN, an infinity or a value near float32's limit (3e38) in an EXR, HDR or PFM input would
reach the sampling probabilities of `--init gradient` ("probabilities contain NaN"), the
losses and the cell means; such images are refused in one line instead (docs/voronoi.md,
docs/splat-gauss.md).
"""

from __future__ import annotations

import numpy as np

from ..errors import UsageError

MAX_PIXEL = 1e6  # |value| allowed: far above any HDR photo's range, while squared errors over 2^26 pixels stay finite


def check_pixels(pixels: np.ndarray, where: str) -> None:
    """UsageError naming `where` (the file, quoted) when a pixel value is NaN, infinite or beyond MAX_PIXEL."""
    values = np.asarray(pixels)
    if values.dtype.kind != "f":
        return  # integer images are bounded by their type
    with np.errstate(invalid="ignore"):
        bad = ~(np.abs(values) <= MAX_PIXEL)  # NaN compares false: counted as bad
    count = int(np.count_nonzero(bad))
    if count:
        first = values[bad].flat[0]
        raise UsageError(
            f"{where} holds {count} pixel values that are NaN, infinite or too large (such as {float(first):.7g}); "
            f"allowed: finite values from {-MAX_PIXEL:g} to {MAX_PIXEL:g}"
        )
