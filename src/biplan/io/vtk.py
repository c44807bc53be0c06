"""VTK export of reconstructed tubes for ParaView: one state (.vtu), a time series (.pvd).

Each state is one unstructured grid (:func:`tube_mesh`, written with meshio) of two cell blocks:

* ``triangle``: the facets of every rigid element, wrapped onto the cylinder
  (:func:`biplan.geometry.surface.reconstruct`), fan-triangulated;
* ``line``: the fold fields (helical creases and circular-fold fields) as wrapped polylines,
  midway in the gaps between the elements.

Point data: ``elongation`` w [mm] (on fold vertices; NaN on element vertices) and
``development`` (z, s) [mm], the position in the planar development. Cell data (one array per
block): ``module`` (0 = base; for a circular fold the module above it), ``element`` (0: ABCD,
1: EFG; −1 on folds), ``fold`` (index into the result files' ``fold`` dimension; −1 on
elements), ``elongation`` [mm] (segment mean; NaN on elements) and ``phase`` (0 closed,
1 spinodal, 2 open; −1 on elements and single-branch folds).

The facets are cut in the reference and moved rigidly, so every state of a tube has the same
points and cells: ParaView's temporal filters apply to a series. A ``.pvd`` collection lists
one ``.vtu`` per saved step (in a folder named after it) with its time [s] or step index.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any
from xml.sax.saxutils import quoteattr

import numpy as np

from biplan.geometry import surface
from biplan.geometry.foldlines import branch_index

if TYPE_CHECKING:
    import meshio

    from biplan.model.assembly import Model

__all__ = ["export_result", "tube_mesh", "write_pvd", "write_vtu"]


def _fold_modules(model: Model) -> np.ndarray:
    """Module index of every fold: n for helical fold n, the upper module of a circular fold."""
    upper = [c.upper for c in model.layout.connectors]
    return np.asarray([*range(model.layout.n_modules), *upper], dtype=np.int64)


def tube_mesh(model: Model, q: np.ndarray, *, subdivisions: int = 48) -> meshio.Mesh:
    """The reconstructed tube of configuration ``q`` as a meshio mesh (see module docstring).

    Parameters
    ----------
    model : Model
    q : ndarray, shape (n_q,)
        Generalised coordinates.
    subdivisions : int
        Facets per circumference.

    Returns
    -------
    meshio.Mesh
        Points [mm] in (x, y, z), z along the axis, the clamp at z = 0.
    """
    import meshio

    rec = surface.reconstruct(
        model.layout,
        model.params.geometry,
        model.kinematics(np.asarray(q, dtype=float)),
        model.kinematics(model.zeros()),
        subdivisions=subdivisions,
    )
    srf, folds = rec.surface, rec.folds
    tri, facet = srf.triangles()
    n_pts, n_seg = len(srf.points), len(folds.segments)
    fold = rec.lines.fold[folds.field]
    laws = [*model.tube.helical_laws, *model.tube.circular_laws]
    w_mid = folds.w[folds.segments].mean(axis=1)
    phase = np.array([branch_index(laws[f], w) for f, w in zip(fold, w_mid, strict=True)])
    none = np.full(len(tri), -1, dtype=np.int64)
    return meshio.Mesh(
        points=np.concatenate([srf.points, folds.points]),
        cells=[("triangle", tri), ("line", folds.segments + n_pts)],
        point_data={
            "elongation": np.r_[np.full(n_pts, np.nan), folds.w],
            "development": np.concatenate([srf.plane, folds.plane]),
        },
        cell_data={
            "module": [srf.module[facet], _fold_modules(model)[fold]],
            "element": [srf.element[facet], np.full(n_seg, -1, dtype=np.int64)],
            "fold": [none, fold],
            "elongation": [np.full(len(tri), np.nan), w_mid],
            "phase": [none, np.where(np.isnan(phase), -1, phase).astype(np.int64)],
        },
    )


def write_vtu(path: str | Path, model: Model, q: np.ndarray, *, subdivisions: int = 48) -> Path:
    """Write configuration ``q`` as a VTK unstructured grid (.vtu); returns the path."""
    path = Path(path)
    tube_mesh(model, q, subdivisions=subdivisions).write(path, file_format="vtu")
    return path


def write_pvd(
    path: str | Path,
    model: Model,
    qs: np.ndarray,
    *,
    times: np.ndarray | None = None,
    subdivisions: int = 48,
) -> Path:
    """Write a series of configurations as a ParaView collection (.pvd) of .vtu files.

    Parameters
    ----------
    path : str or Path
        The ``.pvd`` file; the ``.vtu`` files go into a folder of the same name without the
        suffix, next to it (``tube.pvd`` → ``tube/tube_0000.vtu``, …).
    model : Model
    qs : ndarray, shape (n_states, n_q)
        The configurations.
    times : ndarray, shape (n_states,), optional
        Time [s] (or any monotonic parameter) of each state; default 0, 1, 2, ….
    subdivisions : int
        Facets per circumference.

    Returns
    -------
    Path
        The ``.pvd`` file.

    Raises
    ------
    ValueError
        If ``times`` does not have one entry per state.
    """
    path = Path(path)
    qs = np.atleast_2d(np.asarray(qs, dtype=float))
    times = np.arange(len(qs), dtype=float) if times is None else np.asarray(times, dtype=float)
    if times.shape != (len(qs),):
        raise ValueError(f"times has shape {times.shape}, expected ({len(qs)},)")
    folder = path.with_suffix("")
    folder.mkdir(parents=True, exist_ok=True)
    entries = []
    for k, (q, t) in enumerate(zip(qs, times, strict=True)):
        vtu = write_vtu(folder / f"{folder.name}_{k:04d}.vtu", model, q, subdivisions=subdivisions)
        rel = quoteattr(vtu.relative_to(path.parent).as_posix())
        entries.append(f'    <DataSet timestep="{float(t)!r}" group="" part="0" file={rel}/>')
    path.write_text(
        '<?xml version="1.0"?>\n'
        '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
        "  <Collection>\n" + "\n".join(entries) + "\n  </Collection>\n</VTKFile>\n",
        encoding="utf-8",
    )
    return path


def export_result(
    dataset: Any, model: Model, path: str | Path, *, stride: int = 1, index: int = -1
) -> Path:
    """Export a result file's configurations: ``.pvd`` (every ``stride``-th) or ``.vtu`` (one).

    Parameters
    ----------
    dataset : xarray.Dataset
        A path, trajectory or state catalogue with ``q(step|time|state, coordinate)``.
    model : Model
        The model the result belongs to (:func:`biplan.io.results.model_of`).
    path : str or Path
        Output file; its suffix picks the format.
    stride : int
        Keep every ``stride``-th state of a series (0, stride, 2·stride, …).
    index : int
        The state written to a ``.vtu`` (default: the last).

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        For another suffix or ``stride`` < 1.
    """
    path = Path(path)
    q = np.asarray(dataset["q"].values, dtype=float)
    if path.suffix == ".vtu":
        return write_vtu(path, model, q[index])
    if path.suffix != ".pvd":
        raise ValueError(f"export to .vtu or .pvd, not {path.suffix!r}")
    if stride < 1:
        raise ValueError(f"stride must be >= 1, got {stride}")
    keep = np.arange(0, len(q), stride)
    dim = dataset["q"].dims[0]
    labels = np.asarray(dataset[dim].values) if dim in dataset.coords else None
    if labels is None or not np.issubdtype(labels.dtype, np.number):
        return write_pvd(path, model, q[keep])
    return write_pvd(path, model, q[keep], times=labels[keep].astype(float))
