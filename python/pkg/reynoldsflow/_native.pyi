"""Types of the compiled module `reynoldsflow._native`; the package's
docstring (`reynoldsflow/__init__.py`) documents the options they share."""

from os import PathLike
from fractions import Fraction
from typing import Any, Dict, Iterator, List, Literal, Optional, Sequence, Tuple, TypedDict, Union, overload

from typing_extensions import NotRequired

import numpy as np
import numpy.typing as npt

__version__: str

Engine = Literal["fixed", "float"]
Scale = Union[str, Tuple[float, float]]
IntensityScale = Union[float, Fraction, Tuple[int, int], str]
Variant = Literal["dc", "dc0", "cd", "hsv"]
Layout = Literal["hwc", "chw"]
Rate = Union[int, float, Fraction, str]
Size = Union[Tuple[int, int], str]
# An (H, W) or (H, W, 1) uint8 array: a NumPy array, or any CPU array that
# exports __dlpack__ or the array interface (a torch tensor), read in place.
Frame = npt.NDArray[np.uint8]
Path = Union[str, PathLike[str]]
# Where a result is written (out=): a writable, C-contiguous uint8 array of
# the result's shape, a NumPy array or a CPU torch tensor; returned as given.
Out = npt.NDArray[np.uint8]

class Settings(TypedDict):
    engine: Engine
    scale: str
    intensity_scale: str
    lam: float
    tile: Optional[Tuple[int, int]]
    variant: Variant
    hsv_max: Optional[float]
    layout: Layout

DEFAULTS: Settings
"""The library's default settings (the Rust host's ``Settings::default()``),
under this API's keyword names: what every function uses for a keyword not
given."""

def settings(
    *,
    engine: Engine = "fixed",
    scale: Scale = "minmax",
    intensity_scale: IntensityScale = ...,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
    variant: Variant = "dc",
    hsv_max: Optional[float] = None,
    layout: Layout = "hwc",
) -> Settings:
    """The settings a call with these keywords computes with, checked as
    every function checks them (a bad value raises the same ``ValueError``):
    ``settings()`` is ``DEFAULTS``; ``settings(lam=1e-6)["intensity_scale"]``
    is ``"1/255"``."""

def represent(
    prev: Frame,
    next: Frame,
    *,
    engine: Engine = "fixed",
    scale: Scale = "minmax",
    intensity_scale: IntensityScale = ...,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
    variant: Variant = "dc",
    hsv_max: Optional[float] = None,
    layout: Layout = "hwc",
) -> npt.NDArray[np.uint8]:
    """The ReynoldsFlow representation of a frame pair: an (H, W, 3) uint8
    image [|v_d|, |v_c|, prev] (variant "dc"), byte for byte what
    ``reynoldsflow pair`` writes to rep.png; layout="chw" gives (3, H, W),
    channels first as torchvision."""

class Fields(TypedDict):
    v_c: npt.NDArray[np.float32]
    v_d: npt.NDArray[np.float32]
    v_R: npt.NDArray[np.float32]

def fields(
    prev: Frame,
    next: Frame,
    *,
    engine: Engine = "fixed",
    intensity_scale: IntensityScale = ...,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
) -> Fields:
    """The curl-free field v_c, the divergence-free field v_d and their sum
    v_R = v_c + v_d, each a float32 (H, W, 2) array, last axis (x, y) in
    pixels (x right, y down), like OpenCV's flow: ``reynoldsflow pair``'s
    float64 .npy planes rounded to float32. With engine="fixed", v_c and
    v_d are the core's float32 values exactly (its planes hold them
    unrounded); v_R is their float64 sum, rounded once."""

def motion_score(
    prev: Frame,
    next: Frame,
    *,
    engine: Engine = "fixed",
    intensity_scale: IntensityScale = ...,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
) -> float:
    """How much a pair moves: the mean over all pixels of |v_R| =
    |v_c + v_d|, in pixels per frame (0.0 for identical frames). Rank or
    threshold clips by it to drop static ones."""

@overload
def represent_clip(
    frames: npt.NDArray[np.uint8],
    *,
    keep_count: bool = False,
    threads: Optional[int] = None,
    return_scores: Literal[False] = False,
    step: Optional[int] = None,
    fps: Optional[Rate] = None,
    source_fps: Optional[Rate] = None,
    resize: Optional[Size] = None,
    short_side: Optional[int] = None,
    layout: Layout = "hwc",
    out: Optional[Out] = None,
    engine: Engine = "fixed",
    scale: Scale = "minmax",
    intensity_scale: IntensityScale = ...,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
    variant: Variant = "dc",
    hsv_max: Optional[float] = None,
) -> npt.NDArray[np.uint8]: ...
@overload
def represent_clip(
    frames: npt.NDArray[np.uint8],
    *,
    keep_count: bool = False,
    threads: Optional[int] = None,
    return_scores: Literal[True],
    step: Optional[int] = None,
    fps: Optional[Rate] = None,
    source_fps: Optional[Rate] = None,
    resize: Optional[Size] = None,
    short_side: Optional[int] = None,
    layout: Layout = "hwc",
    out: Optional[Out] = None,
    engine: Engine = "fixed",
    scale: Scale = "minmax",
    intensity_scale: IntensityScale = ...,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
    variant: Variant = "dc",
    hsv_max: Optional[float] = None,
) -> Tuple[npt.NDArray[np.uint8], npt.NDArray[np.float64]]:
    """Every consecutive pair of a (T, H, W) or (T, H, W, 1) uint8 clip
    (T >= 2): a (T - 1, H, W, 3) array whose image i is
    represent(frames[i], frames[i + 1]); with keep_count=True, (T, H, W, 3),
    the last image repeated so every frame has one. Pairs run on ``threads``
    workers (default: every core); the bytes do not depend on it. With
    return_scores=True, also the float64 (T - 1,) motion_score of each pair.

    step=K takes frames 0, K, 2K, ... (pairs (0, K), (K, 2K), ...); fps=F
    takes F frames per second of the clip's rate source_fps (frame
    floor(k * source_fps / F)); resize=(W, H) or short_side=N resizes the
    frames taken, as ``reynoldsflow run --step/--fps/--resize/--short-side``
    do (docs/resample.md). layout="chw" gives (T - 1, 3, H, W).

    out: a writable, C-contiguous uint8 array (or CPU tensor) of the
    result's shape to write the images into, returned in place of a new
    array; a wrong dtype raises TypeError, a wrong shape, strides or a
    read-only array ValueError."""

class Stream:
    """Frames pushed one at a time (a camera, a decoder), paired as the
    GStreamer element and the ROS 2 node pair them: each frame with the one
    before, every image the same bytes as represent(previous, this).

    first_frame: "drop" (the default) gives nothing for a first frame;
    "black" an all-zero image; "repeat" a copy of the first pair's image,
    given with it at the second frame (feed() and end() only). Each pair is
    computed on `threads` threads (default every core)."""

    def __init__(
        self,
        width: int,
        height: int,
        *,
        first_frame: Literal["drop", "repeat", "black"] = "drop",
        threads: Optional[int] = None,
        engine: Engine = "fixed",
        scale: Scale = "minmax",
        intensity_scale: IntensityScale = ...,
        lam: float = 1e-4,
        tile: Optional[Tuple[int, int]] = None,
        variant: Variant = "dc",
        hsv_max: Optional[float] = None,
        layout: Layout = "hwc",
    ) -> None: ...
    def push(self, frame: Frame, *, out: Optional[Out] = None) -> Optional[npt.NDArray[np.uint8]]:
        """This frame's image ((height, width, 3), or (3, height, width) with
        layout="chw"): the representation of
        (previous frame, frame), or for a first frame (since the start,
        end() or reset()) None, or with first_frame="black" zeros. With out
        (as represent_clip's), the image is written into it and out
        returned. Raises ValueError with first_frame="repeat": use feed()."""
    def feed(self, frame: Frame) -> List[npt.NDArray[np.uint8]]:
        """Every image this frame gives, in order: none or one, and with
        first_frame="repeat" two at the second frame."""
    def end(self) -> List[npt.NDArray[np.uint8]]:
        """The stream ends here: the images it still owes (with
        first_frame="repeat", a lone first frame paired with itself); the
        next frame is a first frame."""
    def reset(self) -> None:
        """Forget the previous frame without an image: the next frame is a
        first frame."""
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def first_frame(self) -> Literal["drop", "repeat", "black"]: ...

class Record(TypedDict):
    path: str
    output: str
    status: Literal["done", "skipped", "failed", "interrupted"]
    frames: Optional[int]
    outputs: Optional[int]
    seconds: float
    error: Optional[str]
    # With step or fps: the input index of every frame used.
    source_frames: NotRequired[list[int]]

def convert(
    src: Path,
    dst: Path,
    *,
    rep: bool = True,
    viz: bool = False,
    hsv_max: Optional[float] = None,
    npy: Union[None, bool, str, Sequence[str]] = None,
    npy_dtype: Literal["f16", "f32", "f64"] = "f64",
    flo: Union[None, bool, str, Sequence[str]] = None,
    image_format: Literal["png", "jpg"] = "png",
    jpeg_quality: int = 95,
    jpeg_subsampling: Literal["444", "420"] = "444",
    png_compression: Literal["fast", "default", "best"] = "fast",
    keep_count: bool = False,
    max_frames: Optional[int] = None,
    step: Optional[int] = None,
    fps: Optional[Rate] = None,
    resize: Optional[Size] = None,
    short_side: Optional[int] = None,
    threads: Optional[int] = None,
    force: bool = False,
    engine: Engine = "fixed",
    scale: Scale = "minmax",
    intensity_scale: IntensityScale = ...,
    lam: float = 1e-4,
    tile: Optional[Tuple[int, int]] = None,
    variant: Variant = "dc",
) -> Record:
    """One video or frame folder ``src`` into the folder ``dst``, exactly as
    ``reynoldsflow dataset`` makes each item (``reynoldsflow run``'s files
    plus the marker .reynoldsflow-done, written last): a finished item is
    skipped when run again with the same options on the same source (size
    and modification time) with all its files there at their sizes;
    otherwise it is redone, the files of earlier settings removed first;
    force=True redoes it.
    npy=True writes v_c, v_d and v_R as .npy (or name them: "v_R" or
    ["v_c", "v_R"]); flo=True writes v_R as .flo. npy_dtype, image_format,
    jpeg_quality, jpeg_subsampling ("444": each pixel's channels kept apart;
    "420": smaller, colour edges blurred), png_compression ("fast", fdeflate;
    "default" and "best", zlib's levels: the same pixels, smaller files,
    more time), step, fps, resize and short_side are the command line's
    flags of the same names (docs/datasets.md). Returns the status record; an input that
    cannot be read gives status "failed" with the reason in "error"; a bad
    option raises."""

def dataset_items(
    src: Path,
    *,
    files_from: Union[None, Path, Sequence[Path]] = None,
    dst: Optional[Path] = None,
    shard: Optional[Tuple[int, int]] = None,
) -> list[Tuple[str, str]]:
    """The items ``reynoldsflow dataset SRC DST`` makes, in its order:
    (video file or frame folder, its output folder relative to DST). With
    files_from, those of that manifest (one path relative to src per line)
    or of that list of paths (each relative to src, or absolute inside it);
    a dst inside src is not searched. With shard=(i, n), only the items
    ``reynoldsflow dataset --shard i/n`` takes (the same hash). An item
    that command would refuse (its output folder another's, or inside
    another's ``hsv/``, ``v_c/``, ``v_d/``, ``v_R/``) raises ValueError."""

class FrameReader:
    """The frames of one video or frame folder (read_frames): an iterator
    of (index in the input, (H, W) uint8 frame)."""

    def __iter__(self) -> Iterator[Tuple[int, npt.NDArray[np.uint8]]]: ...
    def __next__(self) -> Tuple[int, npt.NDArray[np.uint8]]: ...
    @property
    def frame_rate(self) -> Optional[Tuple[int, int]]:
        """Frames per second of the frames given, (num, den), when the
        input states a rate (None for frame folders, or once ended)."""

def read_frames(
    path: Path,
    *,
    step: Optional[int] = None,
    fps: Optional[Rate] = None,
    resize: Optional[Size] = None,
    short_side: Optional[int] = None,
    max_frames: Optional[int] = None,
) -> FrameReader:
    """The frames of a video (Y4M, or anything ffmpeg decodes) or frame
    folder, one at a time, as ``reynoldsflow dataset`` reads an item, with
    step, fps, resize and short_side applied; max_frames counts the frames
    taken."""

def set_max_pixels(n: int) -> None:
    """The most pixels (width x height) a frame of this process may have,
    at least 1 (default 8192 x 8192): every entry point (the readers,
    ``represent``, ``fields``, ``motion_score``, ``represent_clip``,
    ``Stream``, ``represent_batch``) refuses a larger frame with the same
    ``ValueError`` before allocating it, as the command line's
    ``--max-pixels``."""

def max_pixels() -> int:
    """The limit ``set_max_pixels`` sets."""

def _check_frame_size(width: int, height: int, subject: str) -> None:
    """The ``ValueError`` of a frame over the ``set_max_pixels`` limit,
    about ``subject`` (for the package's functions written in Python)."""

def _settings(function: str, options: Optional[Dict[str, Any]] = None) -> Settings:
    """``settings(**options)``, its errors naming ``function``."""

def read_flo(path: Path) -> npt.NDArray[np.float32]:
    """A Middlebury .flo file as an (H, W, 2) float32 array, last axis (u, v)."""

def write_flo(path: Path, flow: npt.NDArray[Union[np.float32, np.float64]]) -> None:
    """Write an (H, W, 2) float array (last axis (x, y)) as a Middlebury
    .flo file (float32), atomically."""
