"""Generate the SYNTHETIC example datasets of ``examples/data`` (see README.md there).

Run from the repository root::

    python examples/data/make_synthetic.py            # all three datasets (~1–2 min)
    python examples/data/make_synthetic.py --skip-mft  # only the two CFT datasets (seconds)

Everything is drawn from fixed seeds, so the files are reproduced byte for byte.

* ``cft_trilinear/`` — 10 trilinear-CFT specimens (force in N, two segments: phase 1 under
  extension, phase 2 under contraction, stored from the far end down to its stability limit);
* ``cft_linear/`` — 10 linear-CFT specimens (pressure in kPa, one segment);
* ``mft_semi_bistable/`` — 5 semi-bistable MFT specimens (pressure in kPa, two segments),
  made from biplan's own displacement-controlled prediction of ``examples/semi_bistable.toml``
  plus specimen scatter and noise: phase 1 up to the first instability, phase 2 after the last
  snap (all circular folds open), nothing in between.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import biplan
from biplan.calibration.fits import CftGeometry
from biplan.calibration.specimens import Segment, Specimen
from biplan.calibration.synthetic import Scatter, sample_segment, synthetic_specimens

HERE = Path(__file__).resolve().parent
#: True laws (SI Table calib) and specimen geometry (R = 2 mm, one circular fold).
TRILINEAR = biplan.TrilinearLaw(stiffness=(0.9, -0.2, 0.6), transitions=(0.2, 1.3))
LINEAR = biplan.LinearLaw(stiffness=1.3)
GEOMETRY = CftGeometry(radius=2.0, n_folds=1)
#: Scatter and noise of the CFT specimens (log-normal SDs; force noise in N).
SCATTER = Scatter(stiffness=0.05, transitions=0.04, noise=0.02, jitter=0.3)
#: MFT specimens: log-normal SD of the force and displacement scales, force noise [N].
MFT_FORCE_SCATTER, MFT_DISPLACEMENT_SCATTER, MFT_NOISE = 0.04, 0.02, 0.02
MFT_MAX_DISPLACEMENT = 11.5
KPA = 1e-3  # N/mm² per kPa


def write_specimen(
    specimen: Specimen, file: Path, *, pressure: bool, note: str, descending: set[str]
) -> None:
    """One CSV: displacement [mm], force [N] or pressure [kPa], segment; '#' comment header."""
    area = GEOMETRY.end_area
    lines = [f"# SYNTHETIC data — {note}", f"# specimen {specimen.name}; see README.md"]
    lines.append(
        "displacement [mm],pressure [kPa],segment"
        if pressure
        else "displacement [mm],force [N],segment"
    )
    for seg in specimen.segments:
        u, f = seg.displacement, seg.force
        if seg.label in descending:
            u, f = u[::-1], f[::-1]
        for x, y in zip(u, f, strict=True):
            value = f"{y / area / KPA:.3f}" if pressure else f"{y:.5f}"
            lines.append(f"{x:.5f},{value},{seg.label}")
    file.write_text("\n".join(lines) + "\n", encoding="utf-8")


def write_all(specimens: tuple[Specimen, ...], folder: Path, **kwargs: object) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("specimen_*.csv"):
        old.unlink()
    for sp in specimens:
        write_specimen(sp, folder / f"{sp.name}.csv", **kwargs)  # type: ignore[arg-type]


def cft_datasets(out: Path) -> None:
    """The two CFT datasets from the true laws."""
    tri = synthetic_specimens(
        TRILINEAR, GEOMETRY, scatter=SCATTER, n_points=(100, 150), extent=0.4, seed=7
    )
    write_all(
        tri,
        out / "cft_trilinear",
        pressure=False,
        note="trilinear CFT, k = (0.9, -0.2, 0.6) N/mm², w = (0.2, 1.3) mm, R = 2 mm, 1 fold",
        descending={"2"},
    )
    lin = synthetic_specimens(
        LINEAR, GEOMETRY, scatter=SCATTER, n_points=(100, 150), extent=0.5, seed=8
    )
    write_all(
        lin,
        out / "cft_linear",
        pressure=True,
        note="linear CFT, k = 1.3 N/mm², R = 2 mm, 1 fold",
        descending=set(),
    )


def mft_dataset(out: Path, steps: int = 115) -> None:
    """Five MFT specimens from biplan's prediction of the semi-bistable design."""
    from biplan.analysis.response.quasistatic import displacement_sweep

    tube = biplan.load_config(HERE.parent / "semi_bistable.toml")
    model = biplan.Model(tube)
    ref = biplan.relaxed_reference(model)
    path = displacement_sweep(
        model, np.linspace(MFT_MAX_DISPLACEMENT / steps, MFT_MAX_DISPLACEMENT, steps), start=ref
    )
    ok = np.isfinite(path.force) & path.stable
    regular = ok & ~path.switched
    first = int(np.argmin(regular))  # first snap: phase 1 ends before it
    last = int(np.flatnonzero(path.switched)[-1])  # last snap: phase 2 starts here
    u = np.concatenate([[0.0], path.displacement])
    f = np.concatenate([[ref.force], path.force])
    u1, f1 = u[: first + 1], f[: first + 1]
    u2, f2 = u[last + 1 :], f[last + 1 :]
    rng = np.random.default_rng(11)
    specimens = []
    for i in range(5):
        s_f = float(np.exp(MFT_FORCE_SCATTER * rng.normal()))
        s_u = float(np.exp(MFT_DISPLACEMENT_SCATTER * rng.normal()))
        segs = []
        for label, (uu, ff) in (("1", (u1, f1)), ("2", (u2, f2))):
            lo, hi = uu[0], uu[-1]
            if label == "2":  # contraction: from a random far end down to the stability limit
                top = hi * rng.uniform(0.93, 1.0)
                x = sample_segment(rng, top, lo, int(rng.integers(60, 81)), 0.3)
            else:
                x = sample_segment(rng, lo, hi, int(rng.integers(60, 81)), 0.3)
            y = s_f * np.interp(x, uu, ff) + MFT_NOISE * rng.normal(size=x.size)
            segs.append(Segment(s_u * x, y, label))
        specimens.append(Specimen(f"specimen_{i + 1:02d}", tuple(segs)))
    write_all(
        tuple(specimens),
        out / "mft_semi_bistable",
        pressure=True,
        note="semi-bistable MFT from biplan's own prediction (examples/semi_bistable.toml)",
        descending={"2"},
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE, help="Output folder.")
    parser.add_argument("--skip-mft", action="store_true", help="Skip the (slow) MFT dataset.")
    args = parser.parse_args()
    cft_datasets(args.out)
    if not args.skip_mft:
        mft_dataset(args.out)


if __name__ == "__main__":
    main()
