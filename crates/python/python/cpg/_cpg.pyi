"""Type stubs of the native module ``cpg._cpg`` (re-exported by ``cpg``)."""

from os import PathLike
from typing import Any, Optional, Sequence, Union, final

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
_F64 = npt.NDArray[np.float64]
_Controls = Union[Sequence[float], npt.ArrayLike, None]

__version__: str
DEFAULT_ACCELERATION_RAD_S2: float
SPLIT_MIN_NEURONS: int
_ArrayLike = npt.ArrayLike

class CpgError(ValueError):
    """An error of the cpg library, with the library's message."""

@final
class Motion:
    """A motion: frames × channels at a sample rate, with its skeleton when read from a file."""

    def __new__(cls, values: _ArrayLike, channels: Sequence[str], rate_hz: float) -> "Motion":
        """A motion from arrays (frames × channels, names ``bone.dof``); it has no skeleton."""

    @property
    def values(self) -> _F64:
        """Frames × channels (degrees for rotations, skeleton units for translations)."""
    @property
    def channels(self) -> list[str]:
        """Channel names (``bone.dof``), one per column."""
    @property
    def rate_hz(self) -> float: ...
    @property
    def n_frames(self) -> int: ...
    @property
    def format(self) -> str:
        """``amc``, or ``bvh (… mm per unit)``."""
    @property
    def skeleton_asf(self) -> Optional[str]:
        """The skeleton as ASF text."""
    @property
    def mm_per_unit(self) -> Optional[float]: ...
    def forward_kinematics(self) -> tuple[_F64, list[str]]:
        """(points, names): frames × points × 3 in mm (y up), the root and every bone's end."""
    def select(self, channels: Sequence[str]) -> "Motion":
        """The motion with only these channels, in this order."""
    def save(self, path: _Path) -> None:
        """Writes BVH (``.bvh``, centimetres) or AMC, atomically."""

def read_motion(
    path: _Path,
    skeleton: Optional[_Path] = None,
    rate_hz: Optional[float] = None,
    bvh_unit_mm: Optional[float] = None,
) -> Motion:
    """Reads AMC (with its ASF ``skeleton``; 120 Hz unless ``rate_hz``) or BVH (its own frame time;
    length unit ``bvh_unit_mm`` or inferred from the figure's size)."""

@final
class Generator:
    """A model run one step at a time from its start state (allocation-free in Rust)."""

    def step(self, control: Optional[_ArrayLike] = None, out: Optional[_F64] = None) -> _F64:
        """One step: the channels for ``control`` (one value per control input); into ``out`` (float64, one value
        per channel) if given."""
    def reset(self) -> None:
        """Back to the model's start state."""
    @property
    def steps(self) -> int: ...
    @property
    def diverged(self) -> bool: ...

@final
class Stream:
    """A model at any tick rate (ticks between its steps interpolated), optionally as HOAP-2 joint angles."""

    def tick(self, control: Optional[_ArrayLike] = None) -> _F64:
        """One tick: channels, or joint angles (rad) within every limit."""
    @property
    def columns(self) -> list[str]: ...
    @property
    def time_s(self) -> float: ...
    @property
    def rate_hz(self) -> float: ...

@final
class Model:
    """A trained CPG (the model files of ``cpg train``)."""

    @property
    def channels(self) -> list[str]: ...
    @property
    def controls(self) -> list[str]: ...
    @property
    def rate_hz(self) -> float: ...
    @property
    def n_neurons(self) -> int: ...
    @property
    def penalty(self) -> float: ...
    @property
    def validation_score(self) -> float: ...
    @property
    def data(self) -> str: ...
    @property
    def skeleton_asf(self) -> Optional[str]: ...
    @property
    def teachers(self) -> list[dict[str, Any]]:
        """label, controls, period_steps, cycle (period × channels, in the channels' units)."""
    def generate(self, steps: int, controls: _Controls = None, threads: Optional[int] = None) -> _F64:
        """Free run: steps × channels. ``controls``: one value per input, or steps × inputs (the last row held);
        default: the first teacher's setting. ``threads``: 1 or more (default: 2 from SPLIT_MIN_NEURONS neurons)."""
    def generator(self) -> Generator: ...
    def stream(
        self,
        rate_hz: float,
        robot: bool = False,
        urdf: Optional[_Path] = None,
        map: Optional[str] = None,
        acceleration_rad_s2: float = 100.0,
    ) -> Stream: ...
    def evaluate(self, seconds: float = 900.0, controls: _Controls = None) -> list[dict[str, Any]]:
        """Free runs and the paper's push at every taught control setting: teacher, controls, stability, recovery."""
    def hoap2(
        self,
        seconds: float,
        rate_hz: Optional[float] = None,
        controls: _Controls = None,
        urdf: Optional[_Path] = None,
        map: Optional[str] = None,
        acceleration_rad_s2: float = 100.0,
    ) -> dict[str, Any]:
        """HOAP-2 commands: joints, rate_hz, positions_rad, velocities_rad_s, accelerations_rad_s2, limits."""
    def to_bytes(self) -> bytes: ...
    def save(self, path: _Path) -> None: ...
    @staticmethod
    def from_bytes(data: Union[bytes, bytearray, memoryview], name: str = "<bytes>") -> "Model": ...

def load(path: _Path) -> Model:
    """Reads a model file."""

def train(config: Union[_Path, dict[str, Any]], seed: Optional[int] = None, allow_unstable: bool = False) -> Model:
    """Trains as ``cpg train`` does, from a configuration file or a dict of the same fields; ``seed`` replaces the
    reservoir seed. An unstable model (best validation score worse than 1) is refused unless ``allow_unstable``."""

def fit(
    y: _ArrayLike,
    rate_hz: float,
    controls: Optional[_ArrayLike] = None,
    channels: Optional[Sequence[str]] = None,
    control_names: Optional[Sequence[str]] = None,
    seed: Optional[int] = None,
    config: Optional[dict[str, Any]] = None,
    allow_unstable: bool = False,
) -> Model:
    """Trains on one recording ``y`` (time × channels; 1-D is one channel; a DataFrame's columns name the channels)
    at ``rate_hz`` frames per second, under ``controls`` (one value per control input); z-scoring inside.
    ``config`` overrides the data, reservoir and training sections (docs/config.md)."""

def fit_segments(
    segments: Sequence[_ArrayLike],
    rate_hz: float,
    controls: Optional[Sequence[_ArrayLike]] = None,
    channels: Optional[Sequence[str]] = None,
    control_names: Optional[Sequence[str]] = None,
    seed: Optional[int] = None,
    config: Optional[dict[str, Any]] = None,
    allow_unstable: bool = False,
) -> Model:
    """Trains on several recordings (each time × channels, the same channels), each under its own control values
    (``controls``: one list per segment); otherwise as ``fit``."""

def hoap2_urdf() -> str:
    """The HOAP-2 URDF the package carries."""

def hoap2_mjcf() -> str:
    """The HOAP-2 MuJoCo scene (MJCF) the package carries: servos, sensors, keyframe ``home``."""

def robot_joints(urdf: Optional[_Path] = None) -> list[dict[str, Any]]:
    """Joints of a URDF: name, parent, child, lower_rad, upper_rad, velocity_rad_s."""

def map_hoap2(
    values: _ArrayLike,
    channels: Sequence[str],
    rate_hz: float,
    urdf: Optional[_Path] = None,
    map: Optional[str] = None,
    acceleration_rad_s2: float = 100.0,
) -> dict[str, Any]:
    """Channels (frames × channels, degrees) onto HOAP-2 joints within every limit."""
