"""Mesh generation by bubble packing (K. Shimada, 1993).

``bubblemesh.mesh`` runs the same engine with the same defaults as the
command line ``bubblemesh mesh``: a STEP or TOML file, or a CadQuery or
build123d object, into triangles (surfaces) and tetrahedra (``dim=3``)::

    import bubblemesh
    m = bubblemesh.mesh("part.step", size=0.8, dim=3)
    m.points, m.tetrahedra      # numpy arrays
    m.write("part.msh")         # .msh .vtu .stl .obj .mesh .svg .png .html
    m.to_meshio()               # a meshio.Mesh

Errors raise :class:`MeshError` (or its subclasses :class:`InputError`,
:class:`SpacingError`, :class:`Cancelled`) with the command line's message;
Ctrl-C raises ``KeyboardInterrupt`` and stops the meshing threads.
"""

from __future__ import annotations

import contextlib
import numbers
import os
import tempfile
import warnings

from ._native import Cancelled, InputError, Mesh, MeshError, SpacingError
from ._native import mesh as _mesh
from ._native import read as _read

__all__ = [
    "mesh",
    "read",
    "Mesh",
    "MeshError",
    "InputError",
    "SpacingError",
    "Cancelled",
    "MeshWarning",
]

__version__ = "0.1.0"


class MeshWarning(UserWarning):
    """A warning of a run (faces meshed finer than asked, elements the
    geometry forces below radius ratio 0.01), worded as the command line."""


def _size(size):
    """(expression text or None, callable or None) of ``size``."""
    if size is None:
        return None, None
    if isinstance(size, bool):
        raise TypeError("size must be a number, an expression string or a callable, not a bool")
    if isinstance(size, numbers.Real):
        return repr(float(size)), None
    if isinstance(size, str):
        return size, None
    if callable(size):
        return None, size
    raise TypeError(
        f"size must be a number, an expression string or a callable, not {type(size).__name__}"
    )


def _view(view):
    """The ``--view-spacing`` text of ``view``: (x, y, z, a) or "X,Y,Z,A"."""
    if view is None or isinstance(view, str):
        return view
    parts = list(view)
    if len(parts) != 4:
        raise InputError(f"view {view!r}: expected four numbers (x, y, z, a)")
    return ",".join(repr(float(p)) for p in parts)


def _plugins(plugins):
    """Plugin specs: each a path, or (path, {key: value}) / (path, ["k=v", ...])."""
    if isinstance(plugins, (str, os.PathLike)):
        plugins = [plugins]
    specs = []
    for p in plugins:
        if isinstance(p, (str, os.PathLike)):
            specs.append((os.fspath(p), []))
            continue
        path, args = p
        if isinstance(args, dict):
            pairs = [(str(k), _arg_text(v)) for k, v in args.items()]
        else:
            pairs = []
            for a in args:
                if isinstance(a, str):
                    k, sep, v = a.partition("=")
                    if not sep:
                        raise InputError(f"plugin argument '{a}': expected KEY=VALUE")
                    pairs.append((k, v))
                else:
                    k, v = a
                    pairs.append((str(k), _arg_text(v)))
        specs.append((os.fspath(path), pairs))
    return specs


def _arg_text(v):
    """A plugin argument's value as text (as the command line would pass it)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return ",".join(_arg_text(x) for x in v)
    return str(v)


def _notebook_progress():
    """A progress callback drawing a tqdm bar in a Jupyter notebook (where
    stderr is no terminal), or None outside one or without tqdm."""
    import sys

    if "ipykernel" not in sys.modules:
        return None
    try:
        from tqdm.auto import tqdm
    except ImportError:
        return None
    bar = tqdm(total=1, unit="step", leave=False)

    def progress(info):
        if info["event"] == "step":
            bar.total = info["max_steps"]
            bar.n = info["step"]
            bar.set_description(f"stage 2 on {['vertex', 'edge', 'face', 'volume'][info['dim']]} {info['entity']}")
            bar.refresh()

    progress.close = bar.close
    return progress


def _export_step(obj, path):
    """Writes a CadQuery or build123d object as STEP through its own library."""
    top = type(obj).__module__.split(".")[0]
    if top == "cadquery":
        import cadquery

        if isinstance(obj, cadquery.Assembly):
            # one volume per part, named after it
            if hasattr(obj, "export"):
                obj.export(path, exportType="STEP")
            else:
                obj.save(path, exportType="STEP")
        else:
            cadquery.exporters.export(obj, path, exportType="STEP")
        return
    if top == "build123d":
        import build123d

        shape = obj
        if not isinstance(obj, build123d.Shape):
            # a builder (BuildPart, BuildSketch, BuildLine): its result
            for attr in ("part", "sketch", "line"):
                if getattr(obj, attr, None) is not None:
                    shape = getattr(obj, attr)
                    break
        if not build123d.export_step(shape, path):
            raise InputError(f"build123d could not export {type(obj).__name__} as STEP")
        return
    raise TypeError(
        "source must be a path (STEP .step/.stp or domain .toml), a CadQuery Workplane/Shape "
        f"or a build123d Part/Shape, not {type(obj).__module__}.{type(obj).__name__}"
    )


@contextlib.contextmanager
def _source_path(source):
    """(path, name) of ``source``: a path as is, a CAD object as a temporary STEP file."""
    if isinstance(source, (str, os.PathLike)):
        yield os.fspath(source), None
        return
    with tempfile.TemporaryDirectory(prefix="bubblemesh-") as tmp:
        path = os.path.join(tmp, "model.step")
        _export_step(source, path)
        yield path, f"<{type(source).__name__}>"


def mesh(
    source,
    size=None,
    dim=None,
    curvature=None,
    view=None,
    plugins=(),
    fast=False,
    threads=None,
    progress=None,
    *,
    unit=None,
    d_min=None,
    d_max=None,
    combine="min",
    circle_points=7,
) -> Mesh:
    """Meshes ``source`` by bubble packing, as ``bubblemesh mesh`` does.

    Parameters
    ----------
    source
        A path to a STEP (``.step``, ``.stp``) or domain (``.toml``) file, or
        a CadQuery ``Workplane``/``Shape``/``Assembly`` or build123d
        ``Part``/``Shape``/builder (exported to a temporary STEP file by its
        own library).
    size
        The node spacing d(x, y, z): a number, an expression string in the
        command line's syntax (``"0.02 + 0.05*x"``), or a callable taking an
        ``(n, 3)`` float64 array of points and returning ``n`` spacings (it
        is called in batches; see docs/python.md). Default: 1/40 of the
        model's bounding-box diagonal, unless ``curvature``, ``view`` or
        ``plugins`` give the spacing.
    dim
        Highest dimension to mesh: 1 edges, 2 faces, 3 volumes. Default: the
        model's; STEP solids mesh their surfaces unless ``dim=3``.
    curvature
        Curvature-based spacing: triangles within this distance of the
        geometry (``--curvature``).
    view
        View-based spacing d = a·|v0 − x|: ``(x, y, z, a)``
        (``--view-spacing``).
    plugins
        Spacing plugins (shared libraries): each a path, or ``(path,
        {key: value})``.
    fast
        Stage 1 only: milliseconds, lower quality (``--fast``).
    threads
        Threads for the relaxation (default: every core); the mesh does not
        depend on it.
    progress
        ``None``: a progress bar when stderr is a terminal (in a Jupyter
        notebook, a tqdm bar when tqdm is installed); ``False``: none;
        a callable: called with a dict (``event``: "stage1", "step", "pass"
        or "done"; ``dim``, ``entity``, ``elapsed``; ``step`` and
        ``max_steps`` for steps, at most every 0.1 s); returning ``False``
        or raising cancels the run (:class:`Cancelled`, or the exception).
    unit, d_min, d_max, combine
        As ``--unit``, ``--d-min``, ``--d-max`` and ``--combine``.
    circle_points
        At least this many nodes per full turn of a curved edge (a hole's
        circle): where the size is coarser, the edge is meshed finer and
        the faces around it grade back (``--circle-points``; 0: the size
        as given).

    Raises
    ------
    InputError
        The source cannot be read or an option is invalid.
    SpacingError
        The size expression, callable or a plugin is invalid or failed.
    MeshError
        Meshing failed.
    KeyboardInterrupt
        Ctrl-C while meshing.
    """
    size_text, size_fn = _size(size)
    if curvature is not None:
        curvature = float(curvature)
    if progress is None:
        callback = _notebook_progress()
        show = callback is None
    elif progress is False:
        show, callback = False, None
    elif progress is True:
        show, callback = True, None
    elif callable(progress):
        show, callback = False, progress
    else:
        raise TypeError("progress must be None, True, False or a callable")
    if threads is not None:
        if isinstance(threads, bool) or not isinstance(threads, numbers.Integral) or threads < 0:
            raise InputError(f"threads={threads!r}: expected a whole number of threads")
        threads = int(threads)
    try:
        with _source_path(source) as (path, name):
            result = _mesh(
                path,
                size=size_text,
                size_fn=size_fn,
                dim=dim,
                curvature=curvature,
                view=_view(view),
                plugins=_plugins(plugins),
                fast=bool(fast),
                threads=threads,
                progress=callback,
                show_progress=show,
                unit=unit,
                d_min=d_min,
                d_max=d_max,
                combine=combine,
                circle_points=int(circle_points),
                name=name,
            )
    finally:
        if progress is None and callback is not None:
            callback.close()
    for w in result.warnings:
        warnings.warn(w, MeshWarning, stacklevel=2)
    return result


def read(path) -> Mesh:
    """Reads a mesh file (.msh .vtu .stl .obj .mesh) into a :class:`Mesh`."""
    return _read(os.fspath(path))
