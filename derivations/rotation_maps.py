"""Rotation maps in sympy: Euler parameters, exponential/log maps, SO(3) Jacobians.

Conventions are those of :mod:`reference.rotation` (scalar-first Euler
parameters ``q = (e0, e)``; ``A(q)`` maps body to inertial components; angular
velocity in the body frame).  The builders below return sympy objects and are
reused by the element and joint derivations; :func:`generate` writes
``reference/generated/rotation_maps.py``.

Sources: Géradin & Cardona, *Flexible Multibody Dynamics* (2001), ch. 4
(exponential map, tangent operators); Nikravesh (1988) for Euler parameters.
"""

from __future__ import annotations

import sympy as sp

from derivations import atan2
from derivations.codegen import Coefficient, Kernel, render_coefficient, render_kernel, render_module, vector

a = sp.Symbol("a")

# Coefficient functions with a removable singularity at a = 0 (a = rotation angle).
# The closed forms of c_cosc, c_sinc3 and c_jinv subtract nearly equal numbers for small a
# (relative round-off ≈ 6 eps/a² for c_sinc3): their series is used up to a = 1, where the
# round-off is below 1.5e-15 and the 26th-order series is exact to double precision (the series
# of c_jinv converges for a < 2π; its omitted term at a = 1 is ~1e-20). c_sinc and c_asinc
# have no cancellation and switch at 0.1.
COEFFICIENTS = [
    Coefficient("c_sinc", sp.sin(a) / a, "sin(a)/a."),
    Coefficient("c_cosc", (1 - sp.cos(a)) / a**2, "(1 - cos a)/a**2, the second coefficient of exp(a~).",
                threshold=1.0, order=26),
    Coefficient("c_sinc3", (a - sp.sin(a)) / a**3, "(a - sin a)/a**3, the third coefficient of the SO(3) Jacobians.",
                threshold=1.0, order=26),
    Coefficient(
        "c_jinv",
        (1 - (a / 2) * sp.cos(a / 2) / sp.sin(a / 2)) / a**2,
        "(1 - (a/2) cot(a/2))/a**2, the quadratic coefficient of the inverse Jacobian (finite up to a = 2 pi).",
        threshold=1.0, order=26,
    ),
    Coefficient("c_asinc", a / sp.sin(a), "a/sin(a), for the logarithm from Euler parameters (a = half angle)."),
]
C = {c.name: sp.Function(c.name) for c in COEFFICIENTS}
USER_FUNCTIONS = [c.name for c in COEFFICIENTS] + ["branch_sign", "atan2_quadrant"]
branch_sign = sp.Function("branch_sign")
atan2_quadrant = sp.Function("atan2_quadrant")
"""``atan2`` of the first quadrant from arithmetic only (derivations/atan2.py): the Beam2 force kernels'
half angle, so that their structure-of-arrays loops vectorise."""

BRANCH_SIGN_SOURCE = '''@kernel
def branch_sign(x):
    """+1.0 for x >= 0 and -1.0 otherwise: picks the shortest-branch Euler parameters."""
    if x >= 0.0:
        return 1.0
    return -1.0
'''


def skew(v) -> sp.Matrix:
    """Skew matrix ``ṽ`` with ``ṽ b = v × b``."""
    return sp.Matrix([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def quat_mul(p, q) -> list:
    """Quaternion product ``p ⊗ q = (p0 q0 − p·q, p0 q + q0 p + p × q)``."""
    p0, pv = p[0], sp.Matrix(p[1:])
    q0, qv = q[0], sp.Matrix(q[1:])
    s = p0 * q0 - pv.dot(qv)
    v = p0 * qv + q0 * pv + pv.cross(qv)
    return [s, v[0], v[1], v[2]]


def quat_conj(q) -> list:
    """Conjugate (inverse of a unit quaternion)."""
    return [q[0], -q[1], -q[2], -q[3]]


def rotation_matrix(q) -> sp.Matrix:
    """``A(q) = (2 e0² − 1) I + 2 (e eᵀ + e0 ẽ)`` (body → inertial)."""
    e0, e = q[0], sp.Matrix(q[1:])
    return (2 * e0**2 - 1) * sp.eye(3) + 2 * (e * e.T + e0 * skew(e))


def norm(v):
    return sp.sqrt(sum(c**2 for c in v))


def exp_matrix(psi) -> sp.Matrix:
    """``exp(ψ̃) = I + (sin a/a) ψ̃ + ((1 − cos a)/a²) ψ̃²``, ``a = |ψ|``."""
    ang = norm(psi)
    S = skew(psi)
    return sp.eye(3) + C["c_sinc"](ang) * S + C["c_cosc"](ang) * S * S


def right_jacobian(psi) -> sp.Matrix:
    """``J_r(ψ) = I − ((1−cos a)/a²) ψ̃ + ((a − sin a)/a³) ψ̃²``.

    ``exp((ψ + δψ)~) ≈ exp(ψ̃) exp((J_r δψ)~)`` (Géradin & Cardona 2001, §4.8).
    """
    ang = norm(psi)
    S = skew(psi)
    return sp.eye(3) - C["c_cosc"](ang) * S + C["c_sinc3"](ang) * S * S


def right_jacobian_inverse(psi) -> sp.Matrix:
    """``J_r⁻¹(ψ) = I + ψ̃/2 + ((1 − (a/2) cot(a/2))/a²) ψ̃²``."""
    ang = norm(psi)
    S = skew(psi)
    return sp.eye(3) + S / 2 + C["c_jinv"](ang) * S * S


def log_quaternion(q) -> list:
    """Rotation vector of the shortest branch: ``ψ = 2 (b / sin b) σ e``.

    ``σ = sign(e0)`` selects the branch with non-negative scalar part,
    ``b = atan2(|e|, σ e0)`` is the half angle, so ``|ψ| = 2b ≤ π``.
    """
    sig = branch_sign(q[0])
    n = norm(q[1:])
    b = sp.atan2(n, sig * q[0])
    return [2 * C["c_asinc"](b) * sig * c for c in q[1:]]


def exp_quaternion(psi) -> list:
    """Euler parameters of ``exp(ψ̃)``: ``(cos(a/2), (sin(a/2)/a) ψ)``."""
    ang = norm(psi)
    return [sp.cos(ang / 2)] + [C["c_sinc"](ang / 2) / 2 * c for c in psi]


def cayley_factor(w, h) -> list:
    """Trapezoidal (Cayley) increment ``p(hω)`` of ``q̇ = ½ q ⊗ (0, ω)``.

    ``p = (1 − h²|ω|²/16, (h/2) ω) / (1 + h²|ω|²/16)``: exactly unit,
    agrees with ``exp(hω)`` to third order in ``h|ω|``.
    """
    s = h**2 * sum(c**2 for c in w) / 16
    return [(1 - s) / (1 + s)] + [(h / 2) * c / (1 + s) for c in w]


def _flat(M: sp.Matrix) -> list:
    return [M[i, j] for i in range(3) for j in range(3)]


def kernels() -> list[Kernel]:
    p, q, psi, w = vector("p", 4), vector("q", 4), vector("psi", 3), vector("w", 3)
    h = sp.Symbol("h", positive=True)
    cay = cayley_factor(w, h)
    q_new = quat_mul(q, cay)
    return [
        Kernel("quat_product", "Quaternion product ``p ⊗ q`` (scalar first).",
               [("p", p, "left factor"), ("q", q, "right factor")],
               [("out", quat_mul(p, q), "p ⊗ q")]),
        Kernel("rotation_matrix", "``A(q)`` (body → inertial), row-major 3×3.",
               [("q", q, "unit Euler parameters")],
               [("out", _flat(rotation_matrix(q)), "A[0,0], A[0,1], …, A[2,2]")]),
        Kernel("cayley_update_scalars",
               "Euler parameters after one step of the trapezoidal rule (paper §3.3):\n"
               "    ``q_new = q ⊗ p(h ω)``, ω in the body frame, held over the step.  On numbers, not arrays:\n"
               "    the explicit step's drift calls it once per node, and an array argument of a call inside a\n"
               "    loop costs numba two atomic reference-count updates per call (reference/jit.py).",
               [(f"q_{k}", q[k], f"Euler parameter {k} at the start of the step") for k in range(4)]
               + [(f"w_{k}", w[k], f"body-frame angular velocity {k} over the step [rad/s]") for k in range(3)]
               + [("h", h, "time step [s]")],
               [], (q_new, "the Euler parameters at the end of the step")),
        Kernel("exp_quaternion", "Euler parameters of the rotation vector ψ.",
               [("psi", psi, "rotation vector [rad]")],
               [("out", exp_quaternion(psi), "unit Euler parameters")]),
        Kernel("log_quaternion", "Rotation vector of the shortest branch (|ψ| ≤ π).",
               [("q", q, "unit Euler parameters")],
               [("out", log_quaternion(q), "rotation vector [rad]")]),
        Kernel("exp_matrix", "``exp(ψ̃)``, row-major 3×3.",
               [("psi", psi, "rotation vector [rad]")],
               [("out", _flat(exp_matrix(psi)), "rotation matrix")]),
        Kernel("right_jacobian", "``J_r(ψ)``, row-major 3×3.",
               [("psi", psi, "rotation vector [rad]")],
               [("out", _flat(right_jacobian(psi)), "right Jacobian (tangent operator)")]),
        Kernel("right_jacobian_inverse", "``J_r(ψ)⁻¹``, row-major 3×3; finite for |ψ| < 2π.",
               [("psi", psi, "rotation vector [rad]")],
               [("out", _flat(right_jacobian_inverse(psi)), "inverse right Jacobian")]),
    ]


def generate() -> str:
    """Source of ``reference/generated/rotation_maps.py``."""
    parts = [render_coefficient(c) for c in COEFFICIENTS] + [BRANCH_SIGN_SOURCE, atan2.source()]
    parts += [render_kernel(k, USER_FUNCTIONS) for k in kernels()]
    return render_module(
        "derivations/rotation_maps.py",
        "Rotation maps: coefficient functions, Euler parameters, exp/log, SO(3) Jacobians.\n\n"
        "Scalar-first Euler parameters; body-frame angular velocity (see reference.rotation).\n"
        "Every array kernel writes its result into the caller's ``out`` array.",
        parts,
    )
