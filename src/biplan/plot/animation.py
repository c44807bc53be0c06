"""Animations of a path, trajectory or stable-branch sweep: development, 3D tube and the F–U
curve (Movie S1).

:func:`animate` renders one frame per saved step (every ``stride``-th) into a figure of three
panels — the planar development with coloured folds, the wrapped tube, and the force against
load-point displacement with a marker at the current state — and writes them as an animated
GIF (Pillow, an octree palette per frame) or an MP4 (H.264 through the ffmpeg binary bundled
with ``imageio-ffmpeg``).

All frames share one fold colour scale and fixed axis limits, and the figure layout is frozen
after the first frame, so nothing but the tube moves; only what moves is drawn again for
each frame, onto the rest drawn once (:func:`_frames`). Each frame is labelled with its step or
time and its number, so no two frames are identical (GIF writers merge identical frames).
The figure is drawn on an Agg canvas of its own: no pyplot state, no backend change.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from biplan.plot.cylinder import cylinder, set_limits3d
from biplan.plot.response import FONT_SIZE, force_displacement
from biplan.plot.tube import add_colorbar, development, elongation_norm, fold_scale

if TYPE_CHECKING:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import Normalize
    from mpl_toolkits.mplot3d.axes3d import Axes3D

    from biplan.model.assembly import Model

__all__ = ["animate", "frame_indices"]

#: Marker of the current state on the F–U curve (Okabe–Ito vermillion).
MARKER_COLOR = "#D55E00"
#: Colours of a GIF frame's palette (GIF's largest).
GIF_COLORS = 256
#: H.264 wants frame sizes divisible by this; frames are padded with white to a multiple.
MACRO_BLOCK = 16


def frame_indices(n_saved: int, stride: int) -> np.ndarray:
    """Indices of the saved steps that become frames: 0, stride, 2·stride, … (< n_saved).

    Raises
    ------
    ValueError
        If ``stride`` < 1.
    """
    if stride < 1:
        raise ValueError(f"stride must be >= 1, got {stride}")
    return np.arange(0, n_saved, stride)


def _curve(dataset: Any) -> SimpleNamespace:
    """The F–U data of a result in the form :func:`force_displacement` reads."""
    n = dataset["force"].size
    stable = dataset["stable"].values if "stable" in dataset else np.ones(n, dtype=np.int8)
    switched = dataset["switched"].values if "switched" in dataset else np.zeros(n)
    extra = {"limit_point": dataset["limit_point"].values} if "limit_point" in dataset else {}
    return SimpleNamespace(
        displacement=np.asarray(dataset["displacement"].values, dtype=float),
        force=np.asarray(dataset["force"].values, dtype=float),
        stable=np.asarray(stable, dtype=bool),
        switched=np.asarray(switched, dtype=bool),
        **extra,
    )


def _frame_label(dataset: Any, k: int, i: int, n: int) -> str:
    if "time" in dataset.dims:
        return f"$t$ = {float(dataset['time'].values[k]):.4g} s  ({i + 1}/{n})"
    return f"step {k}  ({i + 1}/{n})"


class _Writer:
    """GIF or MP4 frame sink with a common ``append``/``close``."""

    def __init__(self, path: Path, fps: float) -> None:
        import imageio.v2 as iio2

        self.suffix, self._path = path.suffix.lower(), path
        if self.suffix == ".gif":
            self._gif: list[Any] = []
            self._duration = 1000.0 / fps  # ms
        elif self.suffix == ".mp4":
            self._mp4 = iio2.get_writer(
                path, format="FFMPEG", mode="I", fps=fps, codec="libx264", quality=8
            )
        else:
            raise ValueError(f"animations are written as .gif or .mp4, not {path.suffix!r}")

    def append(self, frame: np.ndarray) -> None:
        if self.suffix == ".gif":
            from PIL import Image

            # an octree palette per frame: 5x faster than Pillow's default median cut
            image = Image.fromarray(frame).quantize(GIF_COLORS, method=Image.Quantize.FASTOCTREE)
            self._gif.append(image)
            return
        h, w = frame.shape[:2]
        pad = ((0, -h % MACRO_BLOCK), (0, -w % MACRO_BLOCK), (0, 0))
        with _quiet_fork():  # the first frame starts the ffmpeg process
            self._mp4.append_data(np.pad(frame, pad, constant_values=255))

    def close(self) -> None:
        if self.suffix == ".gif":
            if self._gif:
                first, *rest = self._gif
                first.save(
                    self._path, save_all=True, append_images=rest, duration=self._duration, loop=0
                )
            return
        with _quiet_fork():
            self._mp4.close()


@contextlib.contextmanager
def _quiet_fork() -> Iterator[None]:
    """Silence JAX's warning about os.fork(): the child process only execs ffmpeg."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", r"os\.fork\(\) was called", RuntimeWarning)
        yield


def _added(ax: Any, before: set[Any]) -> list[Any]:
    """The artists of ``ax`` not in ``before``, in drawing (z) order."""
    return sorted((a for a in ax.get_children() if a not in before), key=lambda a: a.get_zorder())


def _background(canvas: Any, moving: list[Any]) -> Any:
    """The figure without the artists that change between frames (axes, ticks, labels, the
    F–U curve and the colorbar stay), to blit every frame onto."""
    for artist in moving:
        artist.set_visible(False)
    canvas.draw()
    for artist in moving:
        artist.set_visible(True)
    return canvas.copy_from_bbox(canvas.figure.bbox)


def animate(
    dataset: Any,
    model: Model,
    path: str | Path,
    *,
    fps: float = 15.0,
    stride: int = 1,
    dpi: float = 100.0,
    color_by: str = "elongation",
    elev: float = 20.0,
    azim: float = -60.0,
) -> Path:
    """Write an animation of a path, trajectory or stable-branch sweep (analogue of the
    paper's Movie S1). States that failed to solve (NaN in a sweep) are not drawn.

    Parameters
    ----------
    dataset : xarray.Dataset
        A path or sweep (dim ``step``) or a trajectory (dim ``time``) with ``q``, ``force``,
        ``displacement`` and ``stable`` (:func:`biplan.io.results.load_result`).
    model : Model
        The model of the result (:func:`biplan.io.results.model_of`).
    path : str or Path
        Output file, ``.gif`` or ``.mp4``.
    fps : float
        Frames per second.
    stride : int
        Use every ``stride``-th saved step (see :func:`frame_indices`).
    dpi : float
        Resolution [dots per inch] of the 7.0 × 3.0 in frames.
    color_by : {"elongation", "phase"}
        Fold colouring of the development and the tube (one scale for all frames).
    elev, azim : float
        View of the tube [degrees].

    Returns
    -------
    Path
        The file written; it holds one frame per solved state of
        ``frame_indices(n_saved, stride)``.

    Raises
    ------
    ValueError
        For another suffix, ``stride`` < 1, ``fps`` ≤ 0, an unknown ``color_by`` or a result
        without steps.
    """
    path = Path(path)
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    qs = np.asarray(dataset["q"].values, dtype=float)
    frames = frame_indices(len(qs), stride)
    frames = frames[np.isfinite(qs[frames]).all(axis=1)]
    if not len(frames):
        raise ValueError("the result has no solved steps to animate")
    norm = elongation_norm(model, qs[frames]) if color_by == "elongation" else None
    norm = fold_scale(color_by, norm, model, qs[frames[0]])[1]
    writer = _Writer(path, fps)
    try:
        for image, _ in _frames(dataset, model, frames, color_by, norm, dpi, (elev, azim)):
            writer.append(image)
    finally:
        writer.close()
    return path


def _frames(
    dataset: Any,
    model: Model,
    frames: np.ndarray,
    color_by: str,
    norm: Normalize | None,
    dpi: float,
    view: tuple[float, float],
) -> Iterator[tuple[np.ndarray, FigureCanvasAgg]]:
    """Render ``frames`` (indices into the result's steps): yield each frame's RGB image
    (H, W, 3) and the canvas, which holds that frame until the next one is asked for.

    The panels are laid out once, on the first frame. The figure without what moves (the
    development's and the tube's artists, the F–U marker and the label) is drawn once as a
    background; every frame restores it and draws only what moves onto it, which gives the
    pixels of a full redraw (tested) without drawing the axes, ticks and curve again.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    qs = np.asarray(dataset["q"].values, dtype=float)
    cmap, norm = fold_scale(color_by, norm, model, qs[frames[0]])
    fig = Figure(figsize=(7.0, 3.0), dpi=dpi, layout="constrained")
    canvas = FigureCanvasAgg(fig)
    grid = fig.add_gridspec(1, 3, width_ratios=[1.0, 1.25, 1.45])
    ax_dev = fig.add_subplot(grid[0])
    ax_tube = cast("Axes3D", fig.add_subplot(grid[1], projection="3d"))
    ax_fu = fig.add_subplot(grid[2])
    curve = _curve(dataset)
    # any object with the F–U arrays; no legend in the small panel of a frame
    force_displacement(cast("Any", curve), ax=ax_fu, legend=False)
    (marker,) = ax_fu.plot([], [], "o", color=MARKER_COLOR, ms=5, zorder=6, gid="marker")
    add_colorbar(ax_dev, color_by, cmap, norm)
    label = fig.suptitle("", fontsize=FONT_SIZE)

    # Fixed limits: the wrapped tube lies on |(x, y)| = R; z spans all frames.
    nodes = np.stack([model.global_nodes(q) for q in qs[frames]])
    dev, radius = model.tube.development, model.tube.development.radius
    pad = 0.04 * dev.circumference
    s_lim = (min(0.0, nodes[..., 1].min()) - pad, max(dev.circumference, nodes[..., 1].max()) + pad)
    z_top = float(nodes[..., 0].max())
    lo3 = np.array([-1.8 * radius, -radius, min(0.0, float(nodes[..., 0].min()))])
    hi3 = np.array([radius, radius, z_top])

    background = None
    for i, k in enumerate(frames):
        before = set(ax_dev.get_children()) | set(ax_tube.get_children())
        development(model, qs[k], ax=ax_dev, color_by=color_by, norm=norm, colorbar=False)
        ax_dev.set(xlim=s_lim, ylim=(-0.6 - pad, z_top + 2 * pad))
        cylinder(model, qs[k], ax=ax_tube, elev=view[0], azim=view[1], color_by=color_by, norm=norm)
        set_limits3d(ax_tube, lo3, hi3)
        marker.set_data([curve.displacement[k]], [curve.force[k]])
        label.set_text(_frame_label(dataset, int(k), i, len(frames)))
        drawn = _added(ax_dev, before)
        moving = [*drawn, ax_tube, marker, label]
        if background is None:
            canvas.draw()  # lays the figure out with every panel in it
            fig.set_layout_engine("none")  # freeze the panel positions
            background = _background(canvas, moving)
        canvas.restore_region(background)
        for artist in moving:
            fig.draw_artist(artist)
        yield np.asarray(canvas.buffer_rgba())[..., :3].copy(), canvas
        for artist in [*drawn, *_added(ax_tube, before)]:
            artist.remove()
