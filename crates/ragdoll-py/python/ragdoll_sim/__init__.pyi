"""Type stubs for ragdoll_sim: see the docstrings of the objects themselves."""

from collections.abc import Callable, Iterator, Mapping, Sequence
from os import PathLike
from typing import Any, Literal, final

import numpy as np
import numpy.typing as npt

__version__: str

_Vec3 = Sequence[float] | npt.ArrayLike
_Path = str | PathLike[str]

__all__ = [
    "Body",
    "BoundError",
    "Cancelled",
    "Character",
    "FileAccessError",
    "FileFormatError",
    "InternalError",
    "Joint",
    "RagdollError",
    "Result",
    "Roles",
    "RoleError",
    "Simulation",
    "SkeletonError",
    "Spec",
    "SpecError",
    "World",
    "__version__",
    "build_ragdoll",
    "humanoid",
    "load",
]

class RagdollError(Exception):
    message: str
    file: str | None
    line: int | None
    place: str | None
    key: str | None
    joint: str | None

class FileFormatError(RagdollError): ...
class FileAccessError(RagdollError): ...
class BoundError(RagdollError): ...
class SkeletonError(RagdollError): ...
class SpecError(RagdollError): ...
class RoleError(RagdollError): ...
class Cancelled(RagdollError): ...
class InternalError(RagdollError): ...

def load(
    path: _Path,
    *,
    units: Literal["m", "cm", "mm", "in"] | None = None,
    height: float | None = None,
    clip: str | int | None = None,
    up: Literal["y", "z"] | None = None,
) -> Character: ...
def humanoid() -> Character: ...
def build_ragdoll(
    character: Character,
    *,
    mass_kg: float | None = None,
    female: bool = False,
    roles: Mapping[str, str] | None = None,
    ignore: Sequence[str] | None = None,
) -> Spec: ...

@final
class Character:
    @staticmethod
    def from_arrays(
        names: Sequence[str],
        parents: npt.ArrayLike,
        rest_local: npt.ArrayLike,
        *,
        mesh: Mapping[str, npt.ArrayLike] | None = None,
        frames: npt.ArrayLike | None = None,
        fps: float = 30.0,
        name: str = "character",
        tips: npt.ArrayLike | None = None,
    ) -> Character: ...
    @property
    def name(self) -> str: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def parents(self) -> list[int]: ...
    @property
    def rest_local(self) -> npt.NDArray[np.float64]: ...
    @property
    def rest_world(self) -> npt.NDArray[np.float64]: ...
    @property
    def tips(self) -> npt.NDArray[np.float64]: ...
    @property
    def height_m(self) -> float: ...
    @property
    def clips(self) -> list[str]: ...
    @property
    def mesh_count(self) -> int: ...
    @property
    def warnings(self) -> list[str]: ...
    @property
    def roles(self) -> Roles: ...
    def __len__(self) -> int: ...

@final
class Roles:
    found: dict[str, str]
    missing: dict[str, str]
    humanoid: bool
    why: str
    warning: str | None
    def __getitem__(self, role: str, /) -> str: ...
    def __contains__(self, role: str, /) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[str]: ...

@final
class Spec:
    @staticmethod
    def from_toml(text: str, path: str = "spec.toml") -> Spec: ...
    @staticmethod
    def load(path: _Path) -> Spec: ...
    def to_toml(self) -> str: ...
    def save(self, path: _Path) -> None: ...
    def validate(self) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def total_mass_kg(self) -> float: ...
    @property
    def bodies(self) -> list[Body]: ...
    @property
    def joints(self) -> list[Joint]: ...
    def body(self, name: str) -> Body: ...
    def joint(self, name: str) -> Joint: ...
    def __copy__(self) -> Spec: ...
    def __deepcopy__(self, memo: Any, /) -> Spec: ...

@final
class Body:
    @property
    def name(self) -> str: ...
    @property
    def bone(self) -> str: ...
    @property
    def role(self) -> str | None: ...
    @property
    def shape(self) -> Literal["capsule", "box"]: ...
    mass_kg: float
    radius_m: float | None
    length_m: float | None
    size_m: tuple[float, float, float] | None
    center_m: tuple[float, float, float]
    rotation: tuple[float, float, float, float]

@final
class Joint:
    @property
    def name(self) -> str: ...
    @property
    def parent(self) -> str: ...
    @property
    def child(self) -> str: ...
    @property
    def kind(self) -> Literal["hinge", "swing_twist", "ball", "fixed"]: ...
    min_deg: float | None
    max_deg: float | None
    swing_deg: float | None
    twist_deg: tuple[float, float] | None
    cone_tilt_deg: tuple[float, float] | None

@final
class World:
    def __new__(cls, backend: Literal["rigid", "fast", "particle"] = "rigid", **settings: Any) -> World: ...
    @staticmethod
    def from_scene(path: _Path) -> World: ...
    @property
    def backend(self) -> str: ...
    def add(
        self,
        character: Character,
        spec: Spec | None = None,
        *,
        at: _Vec3 | None = None,
        facing_deg: float = 0.0,
        name: str | None = None,
        activate: Literal["start", "blast", "contact"] | float | None = None,
        clip_offset_s: float = 0.0,
        powered: float | Mapping[str, Any] | None = None,
        mass_kg: float | None = None,
        female: bool = False,
    ) -> int: ...
    def add_blast(self, tnt_kg: float, at: _Vec3, time_s: float = 0.0, air: bool = False, scale: float = 1.0) -> None: ...
    def add_projectile(
        self,
        origin: _Vec3,
        *,
        direction: _Vec3 | None = None,
        target: _Vec3 | None = None,
        mass_kg: float = 0.008,
        speed_mps: float = 360.0,
        time_s: float = 0.0,
        count: int = 1,
        interval_s: float = 0.1,
    ) -> None: ...
    def add_push(
        self,
        handle: int,
        target: str,
        *,
        impulse_ns: _Vec3 | None = None,
        time_s: float = 0.0,
        force_n: _Vec3 | None = None,
        start_s: float = 0.0,
        end_s: float | None = None,
    ) -> None: ...
    def add_field(
        self,
        kind: Literal["gravity", "radial", "drag", "wind"],
        *,
        keys: Sequence[tuple[float, _Vec3]] | None = None,
        center: _Vec3 | None = None,
        strength_mps2: float = 0.0,
        radius_m: float = 1.0,
        rate_per_s: float = 0.0,
        velocity_mps: _Vec3 | None = None,
        start_s: float = 0.0,
        end_s: float | None = None,
    ) -> None: ...
    def add_pin(
        self,
        handle: int,
        target: str,
        position: _Vec3 | None = None,
        *,
        keys: Sequence[tuple[float, _Vec3]] | None = None,
        stiffness_hz: float | None = None,
        damping_ratio: float = 1.0,
        release_s: float | None = None,
    ) -> None: ...
    def add_drag(
        self,
        handle: int,
        target: str,
        keys: Sequence[tuple[float, _Vec3]],
        *,
        stiffness_hz: float | None = None,
        damping_ratio: float = 1.0,
        release_s: float | None = None,
    ) -> None: ...
    def run(
        self,
        seconds: float | None = None,
        fps: float | None = None,
        progress: Callable[[int, int], bool | None] | None = None,
    ) -> Result: ...
    def __len__(self) -> int: ...

@final
class Result:
    def transforms(self, handle: int = 0, space: Literal["local", "world"] = "local") -> npt.NDArray[np.float64]: ...
    @property
    def report(self) -> dict[str, Any]: ...
    @property
    def frames(self) -> int: ...
    @property
    def fps(self) -> float: ...
    @property
    def names(self) -> list[str]: ...
    def spec(self, handle: int) -> Spec: ...
    def save(self, path: _Path, handle: int | None = None) -> None: ...
    def __len__(self) -> int: ...

@final
class Simulation:
    def __new__(cls, backend: Literal["rigid", "fast", "particle"] = "rigid", **settings: Any) -> Simulation: ...
    def add(
        self,
        character: Character,
        spec: Spec | None = None,
        *,
        at: _Vec3 | None = None,
        facing_deg: float = 0.0,
    ) -> int: ...
    def remove(self, handle: int) -> None: ...
    def add_blast(self, tnt_kg: float, at: _Vec3, *, time_s: float | None = None, air: bool = False, scale: float = 1.0) -> None: ...
    def add_projectile(
        self,
        origin: _Vec3,
        *,
        direction: _Vec3 | None = None,
        target: _Vec3 | None = None,
        mass_kg: float = 0.008,
        speed_mps: float = 360.0,
        time_s: float | None = None,
    ) -> None: ...
    def add_push(self, handle: int, target: str, impulse_ns: _Vec3, *, time_s: float | None = None) -> None: ...
    def add_field(
        self,
        kind: Literal["gravity", "radial", "drag", "wind"],
        *,
        keys: Sequence[tuple[float, _Vec3]] | None = None,
        center: _Vec3 | None = None,
        strength_mps2: float = 0.0,
        radius_m: float = 1.0,
        rate_per_s: float = 0.0,
        velocity_mps: _Vec3 | None = None,
        start_s: float | None = None,
        end_s: float | None = None,
    ) -> None: ...
    def add_pin(
        self,
        handle: int,
        target: str,
        position: _Vec3 | None = None,
        *,
        keys: Sequence[tuple[float, _Vec3]] | None = None,
        stiffness_hz: float | None = None,
        damping_ratio: float = 1.0,
        release_s: float | None = None,
    ) -> None: ...
    def add_drag(
        self,
        handle: int,
        target: str,
        keys: Sequence[tuple[float, _Vec3]],
        *,
        stiffness_hz: float | None = None,
        damping_ratio: float = 1.0,
        release_s: float | None = None,
    ) -> None: ...
    def body_velocities(self, handle: int) -> npt.NDArray[np.float64]: ...
    def step(self, seconds: float) -> None: ...
    @property
    def time(self) -> float: ...
    def body_poses(self, handle: int) -> npt.NDArray[np.float64]: ...
    def transforms(self, handle: int) -> npt.NDArray[np.float64]: ...
    def __len__(self) -> int: ...
