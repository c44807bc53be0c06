"""The kinematics of a configuration from the compiled system, without JAX (MODEL §4–9).

:func:`kinematics` returns the :class:`biplan.geometry.chain.Kinematics` of q — the arrays of
the JAX :func:`biplan.geometry.chain.kinematics` (equal to 1e-12 on the oracle layouts,
``tests/test_system_oracle.py``) — from the compiled element kernels:

* local nodes: each rigid element's map r = R(φ_e)(r0 − P_e) + P_e + [u, 0] of the reference
  nodes (SI Eq. 10), P_e the element's pivot (A or G);
* guides and helical boundary elongations (g_C, g_F, w0, wa): :func:`.elements.module_rows`;
* connector elongations at the field ends: :func:`.elements.connector_points`, and the fields'
  start, end and length from the point tables;
* module frames: the chain of connector increments (α_c, t_c) under the model's readings
  (:func:`.inertia_chain.terms`), θ_up = θ_lo + α_c and o_up = o_lo + R(θ_lo) t_c.

Figures, exports and the fold readings of :class:`biplan.Model` use it (:meth:`Model.kinematics
<biplan.model.assembly.Model.kinematics>`), so drawing a tube compiles nothing per layout and
does not start JAX.
"""

from __future__ import annotations

import numpy as np

from biplan._compile.numba_cache import kernel_array
from biplan.geometry.chain import Kinematics
from biplan.geometry.module import PIVOT
from biplan.model.system.elements import connector_points, module_rows
from biplan.model.system.inertia_chain import terms
from biplan.model.system.tables import SystemData

__all__ = ["kinematics"]

#: The element (0: ABCD, 1: EFG) of each node A..G.
NODE_ELEMENT = np.array([0, 0, 0, 0, 1, 1, 1])


def _local_nodes(ref: np.ndarray, qm: np.ndarray) -> np.ndarray:
    """Deformed nodes (N, 7, 2) [mm] in each module frame: r = R(φ_e)(r0 − P_e) + P_e + [u, 0]."""
    phi = qm[:, 1 + NODE_ELEMENT]  # (N, 7)
    pivot = ref[:, np.asarray(PIVOT)[NODE_ELEMENT]]  # (N, 7, 2)
    dz, ds = ref[..., 0] - pivot[..., 0], ref[..., 1] - pivot[..., 1]
    c, s = np.cos(phi), np.sin(phi)
    z = c * dz - s * ds + pivot[..., 0] + qm[:, :1]
    return np.stack([z, s * dz + c * ds + pivot[..., 1]], axis=-1)


def _frames(d: SystemData, q: np.ndarray) -> np.ndarray:
    """Homogeneous frames (N, 3, 3) of the modules in the global (z, s) plane."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    chain = terms(d, q, np.zeros(q.shape[0]), np.zeros((2 * n, 2)))
    t, theta_term = chain[4], chain[8]
    theta = theta_term[nc : nc + 2 * n : 2]  # a module's angle: that of its first body term
    origin = np.zeros((n, 2))
    for c in range(nc):  # connectors run up the chain: the lower frame is known
        lo, up = d.conn_lower[c], d.conn_upper[c]
        ct, st = np.cos(theta_term[c]), np.sin(theta_term[c])
        step = np.array([ct * t[c, 0] - st * t[c, 1], st * t[c, 0] + ct * t[c, 1]])
        origin[up] = (origin[lo] if lo >= 0 else 0.0) + step
    frames = np.zeros((n, 3, 3))
    frames[:, 0, 0] = frames[:, 1, 1] = np.cos(theta)
    frames[:, 1, 0] = np.sin(theta)
    frames[:, 0, 1] = -frames[:, 1, 0]
    frames[:, :2, 2] = origin
    frames[:, 2, 2] = 1.0
    return frames


def _connector_elongations(d: SystemData, q: np.ndarray) -> np.ndarray:
    """Elongation w [mm] at every connector field end (K,) (SI Eq. VC_w)."""
    n, nc = d.ref.shape[0], d.conn_upper.shape[0]
    w = np.zeros(d.point_s.shape[0])
    x = np.zeros(7)
    for c in range(nc):
        lo, up = int(d.conn_lower[c]), int(d.conn_upper[c])
        x[:3] = 0.0 if lo < 0 else q[3 * lo : 3 * lo + 3]
        x[3:6] = q[3 * up : 3 * up + 3]
        x[6] = q[3 * n + c]
        first, last = int(d.conn_first_point[c]), int(d.conn_first_point[c + 1])
        w[first:last] = connector_points(
            x,
            d.ref[max(lo, 0)],
            d.ref[up],
            float(d.scalars[0]),
            first,
            last,
            d.point_s,
            d.point_upper_element,
            d.point_lower_element,
            d.point_rigid,
            d.point_height,
            d.point_flip,
        )[0]
    return w


def kinematics(d: SystemData, q: np.ndarray) -> Kinematics:
    """The :class:`~biplan.geometry.chain.Kinematics` of q (n_q,) (NumPy; module docstring).

    Parameters
    ----------
    d : SystemData
        The tube as arrays (:attr:`biplan.model.system.System.data`).
    q : ndarray, shape (n_q,)
        Generalised coordinates [mm, rad].

    Returns
    -------
    Kinematics
        Local and reference nodes (N, 7, 2) [mm], guides (2N,), helical boundary elongations
        (N, 2), the helical field length a, connector elongations at the field ends (K,), the
        fields' start, end elongations and lengths (F,) [mm], and the module frames (N, 3, 3).
    """
    q = kernel_array(q, float)
    n = d.ref.shape[0]
    qm = q[: 3 * n].reshape(n, 3)
    rows = np.array(
        [module_rows(kernel_array(qm[m]), d.ref[m], d.n_c[m], d.n_sp[m])[0] for m in range(n)]
    ).reshape(n, 4)
    point_w = _connector_elongations(d, q)
    return Kinematics(
        local_nodes=_local_nodes(d.ref, qm),
        reference=d.ref.copy(),
        guides=rows[:, :2].reshape(-1),
        helical=rows[:, 2:].copy(),
        helical_length=float(d.scalars[2]),
        point_w=point_w,
        field_start=point_w[d.field_start],
        field_end=point_w[d.field_end],
        field_length=d.point_s[d.field_end] - d.point_s[d.field_start],
        frames=_frames(d, q),
    )
