"""Type stubs of bubblemesh (see __init__.py and docs/python.md)."""

import os
from typing import Any, Callable, Dict, Iterable, List, Literal, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

PathLike = Union[str, "os.PathLike[str]"]
SpacingFn = Callable[[npt.NDArray[np.float64]], npt.ArrayLike]
PluginSpec = Union[PathLike, Tuple[PathLike, Union[Dict[str, Any], Sequence[str]]]]
ProgressFn = Callable[[Dict[str, Any]], Optional[bool]]

class MeshError(Exception):
    """Meshing failed; the message is the command line's."""

class InputError(MeshError):
    """The input (file, model, option) could not be read or is invalid."""

class SpacingError(MeshError):
    """The spacing (size expression, callable, plugin) is invalid or failed."""

class Cancelled(MeshError):
    """Meshing was cancelled by the progress callback."""

class MeshWarning(UserWarning):
    """A warning of a run, worded as the command line."""

class Mesh:
    """A mesh: nodes, elements with the model entity each meshes, its
    spacing and report."""

    @property
    def points(self) -> npt.NDArray[np.float64]:
        """Node coordinates, shape (n, 3)."""
    @property
    def triangles(self) -> npt.NDArray[np.int64]:
        """Triangles, shape (m, 3), 0-based node indices."""
    @property
    def tetrahedra(self) -> npt.NDArray[np.int64]:
        """Tetrahedra, shape (m, 4), 0-based node indices (positive volume)."""
    @property
    def lines(self) -> npt.NDArray[np.int64]:
        """Edge elements, shape (m, 2), 0-based node indices."""
    @property
    def triangle_entities(self) -> npt.NDArray[np.int64]:
        """The face id of each triangle."""
    @property
    def tetrahedron_entities(self) -> npt.NDArray[np.int64]:
        """The volume id of each tetrahedron."""
    @property
    def line_entities(self) -> npt.NDArray[np.int64]:
        """The edge id of each line element."""
    @property
    def entity_names(self) -> Dict[Tuple[int, int], str]:
        """Entity names by (dim, id)."""
    @property
    def warnings(self) -> List[str]:
        """The run's warnings, as the command line prints them."""
    @property
    def spacing_note(self) -> str:
        """The spacing the mesh was made with, described."""
    def write(
        self,
        path: PathLike,
        color: Literal["quality", "entity"] = "quality",
        view: Optional[Tuple[float, float, float]] = None,
        bubbles: bool = False,
        width: int = 1000,
    ) -> None:
        """Writes .msh .vtu .stl .obj .mesh or a picture .svg .png .html,
        whole or not at all."""
    def quality(self) -> Dict[str, Any]:
        """The quality report (as `bubblemesh quality --json`)."""
    def quality_table(self) -> str:
        """The quality table the command line prints."""
    def report(self) -> Dict[str, Any]:
        """The run's report (as `bubblemesh mesh --report`)."""
    def html(self) -> str:
        """The self-contained HTML viewer page."""
    def to_meshio(self) -> Any:
        """A meshio.Mesh (needs meshio)."""
    def _repr_html_(self) -> str: ...

def mesh(
    source: Union[PathLike, Any],
    size: Union[None, float, str, SpacingFn] = None,
    dim: Optional[int] = None,
    curvature: Optional[float] = None,
    view: Union[None, str, Sequence[float]] = None,
    plugins: Iterable[PluginSpec] = (),
    fast: bool = False,
    threads: Optional[int] = None,
    progress: Union[None, bool, ProgressFn] = None,
    *,
    unit: Optional[Literal["mm", "cm", "m", "in", "ft"]] = None,
    d_min: Optional[float] = None,
    d_max: Optional[float] = None,
    combine: Literal["min", "product"] = "min",
    circle_points: int = 7,
) -> Mesh:
    """Meshes a STEP/TOML file or a CadQuery/build123d object by bubble
    packing, as `bubblemesh mesh` does."""

def read(path: PathLike) -> Mesh:
    """Reads a mesh file into a Mesh."""
