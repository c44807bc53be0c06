"""The compiled system (Numba, :mod:`biplan.model.system`) equals the JAX autodiff model.

Its derivatives are written by hand; here they are proved against the JAX model
(:meth:`biplan.Model.residual` / :meth:`biplan.Model.jacobian`, autodiff) to 1e-10 relative to
max(1, max|·|) on every layout and reading the compiled kernels cover: the semi-bistable design
(base TPC, SPC/TPC alternation), the fully bistable design under the default chain readings (no
base fold), one module, the MINIMUM contact form, the printed TPC sign, the POINT mirror (3-field
connectors), a mirrored first module, the SEAM and SPLIT load points and per-fold laws; under
force control, displacement control and at rest; at random states whose fields straddle the law
breakpoints (non-zero multipliers), at solved states with active contacts, with the proximal
bias. The element law integral :func:`biplan.model.system.fields.field_energy` is checked on
its own (finite differences, JAX), and the Jacobian against finite differences of the compiled
residual (independent of JAX).

Each JAX layout compiles once (its kernels are cached per layout, and law rows, bias and load
are traced), so the layouts below are few and combine readings.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import biplan
from biplan._compile.setup import jax, jnp, xla_options
from biplan.geometry import chain
from biplan.laws import _jax as law_jax
from biplan.model.params import Load
from biplan.model.system import System
from biplan.model.system.fields import field_energy
from biplan.options import (
    ChainAttachment,
    ChainOffset,
    ContactForm,
    LoadPoint,
    MirrorConvention,
    ModelOptions,
    ModuleKind,
    TpcSign,
)
from conftest import breakpoints_of, make_tube, min_breakpoint_distance, random_configuration

TOL = 1e-10

#: One tube per JAX layout; each combines readings so that the file compiles few layouts.
LAYOUTS = {
    # 6 modules S, M, …: base TPC, then SPC/TPC; centroid of a two-segment (M) end edge
    "semi-bistable": lambda: biplan.designs.semi_bistable(),
    # 4 modules, no base fold, trilinear helical laws; the default chain readings
    "fully bistable": lambda: biplan.designs.fully_bistable(ModelOptions()),
    "one module": lambda: make_tube(1),
    # R1 paper offset: the clamp, SPC frames turned by the lower element
    "paper offset": lambda: make_tube(3).with_options(chain_offset=ChainOffset.PAPER),
    # R3 edge fit: the base connector's clamp line, split (two-segment) edges of the TPCs
    "semi-bistable, edge fit": lambda: biplan.designs.semi_bistable(
        ModelOptions(chain_attachment=ChainAttachment.EDGE_FIT)
    ),
    # connectors TPC, SPC, TPC with the TPCs' first fields mirrored about γ
    "minimum contact, printed TPC sign, seam load": lambda: make_tube(3).with_options(
        contact=ContactForm.MINIMUM, tpc_sign=TpcSign.AS_PRINTED, load_point=LoadPoint.SEAM
    ),
    # modules M, S, M: connectors SPC (base), 3PC, SPC; split node of a two-segment end edge
    "point mirror, first mirrored, split load": lambda: make_tube(3).with_options(
        mirror=MirrorConvention.POINT,
        first_module=ModuleKind.MIRRORED,
        load_point=LoadPoint.SPLIT,
    ),
    # modules M, S, no base fold: one TPC; split point inside a one-segment (S) end edge
    "no base fold, first mirrored, split load": lambda: make_tube(2, base_fold=False).with_options(
        first_module=ModuleKind.MIRRORED, load_point=LoadPoint.SPLIT
    ),
}

LOADS = {
    "force": Load(1.3, 0.0, 0.0),
    "displacement": Load(0.0, 0.7, 1.0),
    "at rest": Load(0.0, 0.0, 0.0),
}

#: A bistable law whose breakpoints the field-energy cases straddle.
LAW = (0.9, -0.37, 0.6, 0.3, 1.3)


@functools.cache
def _model(name: str) -> biplan.Model:
    return biplan.Model(LAYOUTS[name]())


def _system(model: biplan.Model, load: Load) -> System:
    return System.of(
        model.tube,
        force=float(load.force),
        displacement=float(load.displacement),
        control=float(load.displacement_control),
    )


def _label(model: biplan.Model, i: int) -> str:
    """The unknown (or residual row) i of z = [q, λ, λ_∂, μ]."""
    nq, ng = model.n_coordinates, model.n_guides
    if i < nq:
        return f"q[{i}]"
    if i < nq + ng:
        return f"λ[{i - nq}]"
    if i < model.n_unknowns - 1:
        return f"λ_∂[{i - nq - ng}]"
    return "μ"


def _assert_close(model: biplan.Model, got, want, what: str) -> None:
    """max|got − want| / max(1, max|want|) < TOL, naming the worst entry."""
    got, want = np.asarray(got, dtype=float), np.asarray(want, dtype=float)
    assert got.shape == want.shape, f"{what}: shape {got.shape} != {want.shape}"
    diff = np.abs(got - want)
    scale = max(1.0, float(np.max(np.abs(want))))
    err = float(diff.max()) / scale
    where = np.unravel_index(int(np.argmax(diff)), diff.shape)
    names = ", ".join(_label(model, int(i)) for i in where)
    assert err < TOL, (
        f"{what}: relative error {err:.3e} at ({names}) = {where}: "
        f"{got[where]!r} vs {want[where]!r} (scale {scale:.3g})"
    )


def _compare(model: biplan.Model, system: System, z: np.ndarray, load: Load, what: str) -> None:
    """Residual and KKT Jacobian of the compiled system equal the JAX model's at z."""
    r, jac = system.residual(z), system.jacobian(z)
    _assert_close(model, r, model.residual(z, load), f"{what}: residual")
    _assert_close(model, jac, model.jacobian(z, load), f"{what}: Jacobian")
    r2, jac2 = system.evaluate(z)  # the one-pass form is the same computation
    np.testing.assert_array_equal(r2, r)
    np.testing.assert_array_equal(jac2, jac)


def _random_state(model: biplan.Model, rng: np.random.Generator, amplitude: float) -> np.ndarray:
    """z at a random q (fields off the breakpoints by ≥ 1e-3 mm) with non-zero multipliers."""
    q = random_configuration(model, rng, amplitude=amplitude)
    return model.pack(
        q,
        rng.normal(0.0, 1.0, model.n_guides),
        rng.uniform(0.1, 1.0, model.n_contacts),
        rng.uniform(0.2, 0.8),
    )


def _straddling(model: biplan.Model, q: np.ndarray) -> tuple[int, int]:
    """Numbers of helical and circular fields whose end elongations (JAX kinematics) lie on
    either side of one of their law's breakpoints."""
    hb, cb = breakpoints_of(model)

    def count(lo, hi, bps):
        return int(np.sum(np.any((lo[:, None] < bps) & (bps < hi[:, None]), axis=1)))

    w = model.kinematics(q).helical  # (N, 2): w0, wa
    helical = count(w.min(axis=1), w.max(axis=1), hb)
    circular = 0
    for c, (w0, w1, _) in enumerate(model.circular_fields(q)):
        circular += count(np.minimum(w0, w1), np.maximum(w0, w1), cb[c][None, :])
    return helical, circular


# --- the element law integral --------------------------------------------------------------

#: (w0, wL) [mm] against LAW's breakpoints w1 = 0.3, w2 = 1.3.
FIELDS = {
    "closed": (0.05, 0.2),
    "spinodal": (0.5, 0.9),
    "open": (1.6, 2.1),
    "negative w": (-0.4, 0.1),
    "straddles w1": (0.1, 0.8),
    "straddles w2": (0.9, 1.7),
    "straddles both": (0.1, 1.7),
    "straddles w1, w0 > wL": (0.8, 0.1),
    "straddles w2, w0 > wL": (1.7, 0.9),
    "straddles both, w0 > wL": (1.9, -0.2),
    "uniform": (0.7, 0.7),
}
#: Fields whose straddle is below the split tolerance (one-piece midpoint rule).
NARROW = {"narrow straddle of w1": (0.3 - 2e-7, 0.3 + 3e-7)}


def _numba_field(w0: float, wl: float, length: float, law=LAW) -> np.ndarray:
    return np.array(field_energy(w0, wl, length, np.asarray(law, dtype=float)))


def test_field_energy_derivatives_equal_finite_differences():
    """(E_a, E_b) and (E_aa, E_ab, E_bb) are central differences of E and of (E_a, E_b), for
    fields on one branch, straddling one and both breakpoints, in either direction."""
    length, h = 2.7, 1e-6
    both = 0
    for name, (a, b) in FIELDS.items():
        e = _numba_field(a, b, length)
        da = (_numba_field(a + h, b, length) - _numba_field(a - h, b, length)) / (2 * h)
        db = (_numba_field(a, b + h, length) - _numba_field(a, b - h, length)) / (2 * h)
        fd = np.array([da[0], db[0], da[1], da[2], db[1], db[2]])
        exact = np.array([e[1], e[2], e[3], e[4], e[4], e[5]])
        err = np.abs(fd - exact) / max(1.0, np.abs(exact).max())
        assert err.max() < 1e-7, (name, fd, exact)
        both += int(min(a, b) < LAW[3] and LAW[4] < max(a, b))
    assert both == 2  # both breakpoints inside a field, in either direction


def test_field_energy_equals_the_jax_law_kernel():
    """E equals biplan.laws._jax.field_energy (JAX) and its derivatives equal JAX's
    autodiff of it, including a straddle below the split tolerance."""
    cases = {**FIELDS, **NARROW}
    length = 2.7
    ab = jnp.asarray(np.array(list(cases.values())))
    law = tuple(jnp.asarray(v) for v in LAW)

    def energy(x):
        return law_jax.field_energy(x[0], x[1], length, law)

    @functools.partial(jax.jit, compiler_options=xla_options())
    def all_three(x):
        return (
            jax.vmap(energy)(x),
            jax.vmap(jax.grad(energy))(x),
            jax.vmap(jax.hessian(energy))(x),
        )

    value, grad, hess = all_three(ab)
    for i, (name, (a, b)) in enumerate(cases.items()):
        e = _numba_field(a, b, length)
        want = np.array(
            [value[i], grad[i, 0], grad[i, 1], hess[i, 0, 0], hess[i, 0, 1], hess[i, 1, 1]]
        )
        err = np.abs(e - want) / max(1.0, np.abs(want).max())
        assert err.max() < 1e-12, (name, e, want)


# --- the KKT system against the JAX model --------------------------------------------------


def test_layouts_are_supported_and_sized_as_the_model():
    for name in LAYOUTS:
        model = _model(name)
        system = _system(model, LOADS["force"])
        assert system.sizes == (model.n_coordinates, model.n_guides, model.n_contacts), name
        assert system.n_unknowns == model.n_unknowns, name
    kinds = [c.kind for c in _model("point mirror, first mirrored, split load").layout.connectors]
    assert "3PC" in kinds


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_kinematics_equal_the_jax_kinematics(name, rng):
    """``Model.kinematics`` (the compiled system's, no JAX) equals the JAX chain kinematics:
    nodes, guides, elongations, fields and frames under every reading, at random states."""
    model = _model(name)
    for amplitude in (0.05, 0.2):
        q = random_configuration(model, rng, amplitude)
        got = model.kinematics(q)
        want = model.autodiff.kinematics(model.params, jnp.asarray(q))
        for field in chain.Kinematics._fields:
            g, w = np.asarray(getattr(got, field)), np.asarray(getattr(want, field))
            assert g.shape == w.shape, (name, field)
            np.testing.assert_allclose(g, w, rtol=0, atol=1e-12, err_msg=f"{name}: {field}")
        assert type(got.frames) is np.ndarray


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_residual_and_jacobian_equal_the_jax_model(name, rng):
    """Random states (fields straddling the breakpoints, non-zero multipliers) under force
    control, displacement control and at rest."""
    model = _model(name)
    base = _system(model, LOADS["force"])
    straddles = np.zeros(2, dtype=int)
    for amplitude in (0.05, 0.2):
        z = _random_state(model, rng, amplitude)
        straddles += _straddling(model, z[: model.n_coordinates])
        for label, load in LOADS.items():
            system = base.at(
                float(load.force), float(load.displacement), float(load.displacement_control)
            )
            _compare(model, system, z, load, f"{name}, {label}, amplitude {amplitude}")
    assert straddles[1] > 0  # some circular field has a breakpoint inside
    if name == "fully bistable":  # trilinear helical laws (the others are linear)
        assert straddles[0] > 0


def test_per_fold_laws_equal_the_jax_model(rng):
    """Different law rows on several folds of one tube (traced: the semi-bistable kernels)."""
    tube = biplan.designs.semi_bistable()
    default = biplan.Model(tube)
    laws = {
        ("helical", 0): biplan.TrilinearLaw(stiffness=(1.6, -0.9, 1.1), transitions=(0.04, 0.25)),
        ("helical", 3): biplan.TrilinearLaw(stiffness=(2.2, -1.2, 0.8), transitions=(0.1, 0.6)),
        ("helical", 5): biplan.LinearLaw(stiffness=0.7),
        ("circular", 0): biplan.TrilinearLaw(stiffness=(1.4, -0.5, 0.9), transitions=(0.15, 0.9)),
        ("circular", 2): biplan.TrilinearLaw(stiffness=(0.6, -0.1, 1.5), transitions=(0.4, 1.6)),
        ("circular", 5): biplan.LinearLaw(stiffness=0.45),
    }
    for fold, law in laws.items():
        tube = tube.with_law(fold, law)
    model = biplan.Model(tube)
    assert model.layout == default.layout
    straddles = np.zeros(2, dtype=int)
    for amplitude in (0.1, 0.3):
        z = _random_state(model, rng, amplitude)
        straddles += _straddling(model, z[: model.n_coordinates])
        for label, load in LOADS.items():
            system = _system(model, load)
            _compare(model, system, z, load, f"per-fold laws, {label}, amplitude {amplitude}")
            # the rows matter here: the design's uniform laws give another system
            uniform = _system(default, load)
            assert np.max(np.abs(uniform.jacobian(z) - system.jacobian(z))) > 1e-3
    assert np.all(straddles > 0)  # helical and circular fields straddle breakpoints


def test_minimum_contact_near_ties_equal_the_jax_model(rng):
    """The smooth minimum's curvature (MINIMUM contact form) where a connector's contact points
    are within a few τ of each other (small angles: every point's w is near γ)."""
    name = "minimum contact, printed TPC sign, seam load"
    model = _model(name)
    z = _random_state(model, rng, 2e-4)
    t = chain.tables(model.layout)
    w = model.kinematics(z[: model.n_coordinates]).point_w[t.contact_pt]
    tau = model.options.smooth_min_width
    largest = []
    for c in range(model.layout.n_connectors):
        wc = w[t.contact_conn == c]
        soft = np.exp(-(wc - wc.min()) / tau)
        largest.append(soft.max() / soft.sum())
    assert min(largest) < 0.9  # no point dominates the smooth minimum of some connector
    for label, load in LOADS.items():
        _compare(model, _system(model, load), z, load, f"{name}, near ties, {label}")


@pytest.fixture(scope="module")
def solved():
    """The semi-bistable design: its relaxed reference and an equilibrium under compression
    (the closed folds' contacts press: active contacts carry multipliers)."""
    model = _model("semi-bistable")
    reference = biplan.relaxed_reference(model)
    load = Load.of_force(-0.5)
    pressed = biplan.solve_equilibrium(model, biplan.Newton(), reference, load)
    assert reference.converged and pressed.converged
    return model, reference, pressed, load


def test_residual_and_jacobian_equal_the_jax_model_at_solved_states(solved):
    model, reference, pressed, load = solved
    q, _, lam_c, _ = model.split(pressed.z)
    gaps = model.contact_gaps(q)
    active = (lam_c > 1e-3) & (np.abs(gaps) < 1e-4)
    assert np.count_nonzero(active) > 0
    assert min_breakpoint_distance(model, q) > 1e-6  # no field end on a breakpoint
    _compare(model, _system(model, load), pressed.z, load, "pressed equilibrium")
    z_disp = pressed.z.copy()
    z_disp[-1] = 0.5  # μ: the end force of displacement control
    held = Load.of_displacement(float(model.load_displacement(q)))
    _compare(model, _system(model, held), z_disp, held, "pressed state, displacement control")
    rest = Load(0.0, 0.0, 0.0)
    _compare(model, _system(model, rest), reference.z, rest, "relaxed reference")
    # both are equilibria of the compiled system
    assert np.max(np.abs(_system(model, load).residual(pressed.z))) < 1e-8


def test_proximal_bias_equals_the_jax_model(solved, rng):
    """½κ‖q − q_a‖² in both: at the pressed equilibrium and at a random state."""
    model, _, pressed, _ = solved
    q = model.split(pressed.z)[0]
    anchor = q + rng.normal(0.0, 0.02, q.shape)
    kappa = 0.7
    biased = model.with_bias(anchor, kappa)
    for z in (pressed.z, _random_state(model, rng, 0.1)):
        for label, load in LOADS.items():
            plain = _system(model, load)
            system = plain.with_bias(anchor, kappa)
            _compare(biased, system, z, load, f"bias, {label}")
            # the bias is there: κ (q − q_a) in the q rows, κ on their diagonal
            shift = system.residual(z) - plain.residual(z)
            nq = model.n_coordinates
            np.testing.assert_allclose(shift[:nq], kappa * (z[:nq] - anchor), atol=1e-12)
            np.testing.assert_array_equal(shift[nq:], 0.0)
            jump = system.jacobian(z) - plain.jacobian(z)
            np.testing.assert_allclose(jump[:nq, :nq], kappa * np.eye(nq), atol=1e-12)
            np.testing.assert_allclose(jump[nq:], 0.0, atol=1e-12)
            np.testing.assert_allclose(jump[:, nq:], 0.0, atol=1e-12)


# --- the Jacobian against the compiled residual ---------------------------------------------


@pytest.mark.parametrize(
    ("name", "label", "amplitude", "h"),
    [
        ("point mirror, first mirrored, split load", "force", 0.1, 1e-4),
        ("point mirror, first mirrored, split load", "displacement", 0.1, 1e-4),
        # the smooth minimum varies on the scale τ / |∂w/∂φ| ~ 1e-4: a smaller step
        ("minimum contact, printed TPC sign, seam load", "displacement", 2e-4, 1e-6),
    ],
)
def test_jacobian_equals_finite_differences_of_the_residual(name, label, amplitude, h, rng):
    """Central differences of the compiled residual (no JAX, Richardson-extrapolated: error
    O(h⁴)), every column of ∂r/∂z: on the layout with 3-field connectors, rigid lower edges and
    the split load point, and on the MINIMUM contact form near ties of its smooth minimum."""
    model = _model(name)
    load = LOADS[label]
    system = _system(model, load)
    z = _random_state(model, rng, amplitude)
    eye = np.eye(model.n_unknowns)

    def central(step):
        return np.stack(
            [
                (system.residual(z + step * e) - system.residual(z - step * e)) / (2 * step)
                for e in eye
            ],
            axis=1,
        )

    fd = (4.0 * central(h / 2) - central(h)) / 3.0
    jac = system.jacobian(z)
    diff = np.abs(jac - fd)
    err = float(diff.max()) / max(1.0, float(np.abs(jac).max()))
    i, j = np.unravel_index(int(np.argmax(diff)), diff.shape)
    assert err < 1e-9, f"{name}, {label}: {err:.2e} at ({_label(model, i)}, {_label(model, j)})"
