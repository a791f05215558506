"""pointfair: denoises 3-D point clouds with the anisotropic mean curvature flow
(Lange & Polthier 2005), on NumPy arrays.

    cloud = pointfair.read("scan.las")            # {'xyz': (N, 3) float64, 'intensity': ...}
    cloud["xyz"] = pointfair.smooth(cloud["xyz"])  # the options of `pointfair smooth`
    pointfair.write("smooth.las", cloud)

See docs/python.md.
"""
from ._pointfair import (
    IoError,
    ParamError,
    __version__,
    curvature,
    read,
    smooth,
    smooth_file,
    write,
)

__all__ = ["IoError", "ParamError", "curvature", "read", "smooth", "smooth_file", "write",
           "__version__"]
