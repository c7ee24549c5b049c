"""ReynoldsFlow: curl-free and divergence-free motion fields of frame pairs,
and their RGB representation [|v_d|, |v_c|, frame n], computed by the same
code as the ``reynoldsflow`` command line (the same bytes).

Frames are 8-bit gray arrays of shape (H, W) or (H, W, 1), any strides:
NumPy arrays, or CPU arrays of other libraries that export ``__dlpack__``
or the array interface (PyTorch tensors, ...), read in place without a
copy. ``reynoldsflow.torch`` (with PyTorch installed) has a transform and
an ``IterableDataset``. A wrong type, dtype or number of dimensions raises ``TypeError``;
a wrong shape or parameter value ``ValueError``; a file that cannot be
read ``OSError`` (``FileNotFoundError``, ...); an array that is not in
host memory (a CUDA or ``"meta"`` tensor) ``TypeError``. The GIL is
released while computing, so threads compute in parallel; an input that
another thread changes during a call gives undefined bytes (hold it
unchanged until the call returns), and a ``Stream`` pushed to from two
threads at once raises ``RuntimeError`` ("Already borrowed").
``DEFAULTS`` holds the defaults below, ``settings(**options)`` what a call
with those options uses.

Options shared by the computing functions (all keyword-only):

- ``engine``: ``"fixed"`` (the core: integer stages and an IEEE float32
  tail, bit for bit what embedded targets compute; default) or ``"float"``
  (the float64 reference).
- ``scale``: ``"minmax"`` (per-frame min-max; default), ``"fixed:KD,KC"``
  or ``(k_d, k_c)``: constant gains of |v_d| and |v_c| (the fixed engine
  rounds them to 1/65536).
- ``intensity_scale``: s in f = pixel * s, 6144/2**32 <= s <= 1; default
  1/255. A float is taken as the exact ratio it rounds from (``1/255``);
  also a ``fractions.Fraction``, a pair ``(num, den)`` or ``"1/255"``.
- ``lam``: the Tikhonov term lambda of the 2x2 solve (default 1e-4).
- ``tile``: ``(width, height)`` tiles for the fixed engine (any size);
  every tiling gives the same bytes.
- ``variant``: the image: ``"dc"`` = [|v_d|, |v_c|, f] (default), ``"dc0"``
  = [|v_d|, 0, f], ``"cd"`` = [|v_c|, |v_d|, f], ``"hsv"`` = colour wheel of
  v_R; ``hsv_max``: its radius in pixels (default: each frame's longest
  vector).
"""

# The compiled module (Rust, PyO3), re-exported whole: `reynoldsflow.X` is
# `reynoldsflow._native.X`. Its types are in _native.pyi.
from ._native import (
    DEFAULTS as DEFAULTS,
    FrameReader as FrameReader,
    Stream as Stream,
    __version__ as __version__,
    convert as convert,
    dataset_items as dataset_items,
    fields as fields,
    max_pixels as max_pixels,
    motion_score as motion_score,
    read_flo as read_flo,
    read_frames as read_frames,
    represent as represent,
    represent_clip as represent_clip,
    set_max_pixels as set_max_pixels,
    settings as settings,
    write_flo as write_flo,
)

__all__ = [
    "DEFAULTS",
    "FrameReader",
    "Stream",
    "convert",
    "dataset_items",
    "fields",
    "max_pixels",
    "motion_score",
    "read_flo",
    "read_frames",
    "represent",
    "represent_clip",
    "set_max_pixels",
    "settings",
    "write_flo",
]
