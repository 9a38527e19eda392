"""``atan2`` of the first quadrant without the C maths library, so that a loop calling it vectorises.

The Beam2 kernels take the half angle of the relative rotation as ``b = atan2(|e|, σ e0)``
(:func:`derivations.rotation_maps.log_quaternion`), both arguments ≥ 0.  libm's ``atan2`` is a call
LLVM cannot vectorise, so the structure-of-arrays kernel (derivations/soa.py) had to leave it to a
scalar loop; :func:`source` writes ``atan2_quadrant``, made of arithmetic and selects only, which the
per-element and the structure-of-arrays kernels both call (the same bits in either).

Method (the classical argument reduction of the arctangent, e.g. Muller, *Elementary Functions*,
3rd ed. 2016, §11.3; coefficients fitted here): with ``a = min(y, x)``, ``b = max(y, x)``, the ratio
``t = a/b ∈ [0, 1]`` is reduced about a centre ``c ∈ {0, ½, 1}`` (a double, so that ``c b`` is exact)
by ``atan(t) = atan(c) + atan(u)``, ``u = (a − c b)/(b + c a)``, |u| ≤ :data:`U_MAX`; ``atan(u) =
u + u z P(z)``, ``z = u²``, with ``P`` the Chebyshev fit of degree :data:`DEGREE` of
``(atan(√z)/√z − 1)/z`` on ``[0, U_MAX²]`` (``mpmath.chebyfit``, 40 digits); ``atan(c)`` and π/2 are
added as two doubles each (their rounding error below 2⁻¹⁰⁶), and ``atan(y/x) = π/2 − atan(x/y)``
when ``y > x``.  The fit's error is below 1e-18 relative to ``atan(u)``; the measured error of the
double evaluation (tests/test_atan2_quadrant.py) is stated in the function's docstring.
"""

from __future__ import annotations

import mpmath

DEGREE = 8
"""Degree of ``P`` in ``z``: the fit's relative error is below 1e-18 at |u| ≤ 0.27."""
SPLIT_HALF = 0.26
"""``t`` above which the centre is ½: above tan ¼ = 0.2553, so that the sum ``atan(½) + atan(u)`` (u < 0)
is at least ¼ and the error of ``u`` stays below an ulp of it (at t = 0.24 it reached 2.6 ulp); |u| ≤ 0.26."""
SPLIT_ONE = 0.72
"""``t`` above which the centre is 1 (|u| ≤ 0.163 on either side)."""
U_MAX = 0.27
"""The fit's range of |u| (the reduction gives at most 0.26)."""


def _two_doubles(value) -> tuple[float, float]:
    hi = float(value)
    return hi, float(value - mpmath.mpf(hi))


def coefficients() -> list[float]:
    """``P``'s coefficients, constant term first, rounded to doubles."""
    with mpmath.workdps(40):
        def p(z):
            if z == 0:
                return mpmath.mpf(-1) / 3
            u = mpmath.sqrt(z)
            return (mpmath.atan(u) / u - 1) / z

        poly, _ = mpmath.chebyfit(p, [0, mpmath.mpf(U_MAX) ** 2], DEGREE + 1, error=True)
        return [float(c) for c in reversed(poly)]


def source() -> str:
    """Source of the kernel ``atan2_quadrant(y, x)`` (for ``reference/generated/rotation_maps.py``)."""
    with mpmath.workdps(40):
        half_hi, half_lo = _two_doubles(mpmath.atan(mpmath.mpf(1) / 2))
        quarter_hi, quarter_lo = _two_doubles(mpmath.pi / 4)
        right_hi, right_lo = _two_doubles(mpmath.pi / 2)
    c = coefficients()
    horner = f"{c[-1]!r}"
    for k in range(len(c) - 2, -1, -1):
        horner = f"({horner})*z + {c[k]!r}"
    return f'''@kernel
def atan2_quadrant(y, x):
    """``atan2(y, x)`` for y ≥ 0, x ≥ 0 (the half angle of the logarithm, :func:`log_quaternion`), in [0, π/2],
    from arithmetic and selects only (no call of the C maths library: a loop calling it vectorises).

    Argument reduction about 0, ½ or 1 and a polynomial of degree {DEGREE} in u² (derivations/atan2.py);
    error at most 1.5 ulp of the result (inherited from the rounded ratio; 1.41 ulp the largest on 40,000
    angles, tests/test_atan2_quadrant.py against 40-digit values; libm's: 0.52).  Both
    arguments 0 give 0; a NaN argument gives NaN.

    Parameters (in this order)
    ----------
    y : float
        the ordinate, ≥ 0 (|e|, the norm of the vector part)
    x : float
        the abscissa, ≥ 0 (σ e0, the scalar part on the shortest branch)
    """
    a, b = y, x
    if y > x:
        a, b = x, y
    c, hi, lo = 0.0, 0.0, 0.0
    if a > {SPLIT_HALF!r}*b:
        c, hi, lo = 0.5, {half_hi!r}, {half_lo!r}
    if a > {SPLIT_ONE!r}*b:
        c, hi, lo = 1.0, {quarter_hi!r}, {quarter_lo!r}
    den = b + c*a
    if den == 0.0:
        den = 1.0
    u = (a - c*b)/den
    z = u*u
    r = hi + (lo + (u + u*z*({horner})))
    if y > x:
        r = ({right_hi!r} - r) + {right_lo!r}
    return r
'''
