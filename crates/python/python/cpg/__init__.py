"""cpg: central pattern generators learnt from motion capture.

A reservoir-computing CPG (wyffels & Schrauwen 2009) trained in seconds from
ASF/AMC or BVH motion, or from numpy arrays shaped (time, channels); run
freely, step by step or at any tick rate; judged by long free runs and a
push; mapped onto the HOAP-2 humanoid within its joint limits. The model
files are those of the ``cpg`` command line.

    >>> import cpg
    >>> walk = cpg.read_motion("35_01.amc", skeleton="35.asf")
    >>> model = cpg.fit(walk.select(["lfemur.rx"]).values, walk.rate_hz)
    >>> y = model.generate(1200)                  # 10 s, shape (1200, 1), degrees
    >>> g = model.generator(); g.step()           # one step, shape (1,)

Arrays go in as anything NumPy reads as numbers (float64 inside). Errors of
the library are raised as :class:`CpgError` (a ``ValueError``) with the
library's message; arguments of the wrong type raise ``TypeError``. Long work
releases the GIL and stops at Ctrl-C (``KeyboardInterrupt``). Models,
generators and errors can be pickled (to worker processes, for example).
"""

from ._cpg import (
    DEFAULT_ACCELERATION_RAD_S2,
    SPLIT_MIN_NEURONS,
    CpgError,
    Generator,
    Model,
    Motion,
    Stream,
    __version__,
    fit,
    fit_segments,
    hoap2_mjcf,
    hoap2_urdf,
    load,
    map_hoap2,
    read_motion,
    robot_joints,
    train,
)

__all__ = [
    "DEFAULT_ACCELERATION_RAD_S2",
    "SPLIT_MIN_NEURONS",
    "CpgError",
    "Generator",
    "Model",
    "Motion",
    "Stream",
    "__version__",
    "fit",
    "fit_segments",
    "hoap2_mjcf",
    "hoap2_urdf",
    "load",
    "map_hoap2",
    "read_motion",
    "robot_joints",
    "train",
]
