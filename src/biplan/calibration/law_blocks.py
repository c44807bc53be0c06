"""A fitted law as a TOML block of the tube-config schema (:mod:`biplan.io.config`):
:func:`law_toml`, and :func:`calibration_toml` with the calibration's provenance, intervals
and residuals as comments.
"""

from __future__ import annotations

from biplan._errors import ConfigError
from biplan.calibration.calibrate import Calibration
from biplan.io.config_writer import law_lines
from biplan.laws import LinearLaw, TrilinearLaw
from biplan.options import TransitionReading

__all__ = ["calibration_toml", "law_toml"]


def _round(x: float, digits: int = 6) -> float:
    return float(f"{x:.{digits}g}")


def law_toml(
    law: TrilinearLaw | LinearLaw,
    fold_set: str,
    *,
    reading: TransitionReading = TransitionReading.ABSOLUTE,
    comments: tuple[str, ...] = (),
) -> str:
    """A ``[laws.<fold_set>]`` TOML block of the tube-config schema (:mod:`biplan.io.config`).

    Parameters
    ----------
    law : TrilinearLaw or LinearLaw
    fold_set : {"circular", "helical"}
    reading : TransitionReading
        How the target config reads ``transitions`` (its ``options.transition_reading``).
    comments : tuple of str
        Lines written as ``#`` comments above the block.
    """
    if fold_set not in ("circular", "helical"):
        raise ConfigError("fold_set", fold_set, "'circular' or 'helical'")
    if isinstance(law, TrilinearLaw):
        k = tuple(_round(v) for v in law.stiffness)
        w = tuple(_round(v) for v in law.transitions)
        law = TrilinearLaw(stiffness=k, transitions=w)  # type: ignore[arg-type]
    else:
        law = LinearLaw(_round(law.stiffness))
    lines = [f"# {c}" if c else "#" for c in comments]
    lines += [f"[laws.{fold_set}]", *law_lines(law, TransitionReading(reading))]
    return "\n".join(lines) + "\n"


def calibration_toml(
    result: Calibration,
    fold_set: str,
    *,
    source: str = "",
    reading: TransitionReading = TransitionReading.ABSOLUTE,
) -> str:
    """The law block of a calibration, with its provenance, intervals and residuals as comments.

    The block drops into a tube config (``[laws.circular]`` or ``[laws.helical]``). The
    calibration's caveats (:attr:`Calibration.caveats`) come first, one ``# warning:`` line
    each.
    """
    geo = result.geometry
    opts = result.options
    kind = "trilinear" if isinstance(result.law, TrilinearLaw) else "linear"
    level = 100 * opts.confidence
    comments = [f"warning: {c.message}" for c in result.caveats]
    comments += [
        f"biplan calibrate {kind}: {result.band.n_specimens} specimens"
        + (f" in {source}" if source else ""),
        f"specimen geometry: R = {geo.radius:g} mm, {geo.n_folds} circular fold(s) in series, "
        f"H = 2πR = {geo.fold_length:.5g} mm (F = H f(w), u = n w)",
    ]
    if kind == "trilinear":
        comments.append(f"breakpoints: {opts.breakpoints.value}")
    comments.append(
        f"bootstrap over specimens: {result.samples.shape[0]} resamples, {level:g} % percentile "
        f"intervals (seed {opts.seed})"
    )
    for e in result.estimates:
        if e.name == "offset" and not opts.offset:
            continue
        comments.append(f"  {e.name} = {e.value:.5g} {e.unit}  [{e.low:.5g}, {e.high:.5g}]")
    comments.append(
        f"fit residual: RMS {result.fit.rms:.4g} N over {result.fit.residual.size} median points"
    )
    if kind == "trilinear":
        reading = TransitionReading(reading)
        comments.append(f'transitions read with options.transition_reading = "{reading.value}"')
    return law_toml(result.law, fold_set, reading=reading, comments=tuple(comments))
