r"""Hook-cable contact: capsule-capsule Hertz-type normal force with Coulomb-STEP friction.

Implements the contact of Sec. III.D.1 (eq. 42) and the Appendix of Zhang et al.,
"Arresting-Cable System for Robust Terminal Landing of Reusable Rockets" (J. Spacecraft Rockets
58(2), 2021): a normal force ``f_n = k delta^e + c delta_dot`` and a friction force
``f_tau = mu(v) f_n`` with the friction coefficient ``mu(v)`` built from the paper's STEP function.
The printed law is re-derived below; the choices and the corrections of the printed equations
are listed under "Normal force", "Friction" and "Approximations".

Geometry. A hook is a set of capsules (line segment + radius: the hook arm of width
``d_h = 0.15 m``, i.e. radius 0.075 m, and a barb); a cable element is the capsule between two
cable nodes with the cable radius (0.02 m for the paper's 20 mm-radius cable, Sec. II.B). Two
capsules touch where their axes come closer than the sum of the radii. Physics is written for one
(hook capsule, cable element) pair in :func:`capsule_contact` and lifted to all hooks x all cable
elements with ``jax.vmap`` in :func:`pairwise_contacts`. World frame, SI units.

Glossary (paper symbol -> name here)
------------------------------------
=================  =========================  ================================================
paper (Appendix)   code                       meaning [unit]
=================  =========================  ================================================
delta              ``penetration``            ``r_hook + r_cable - |gap|``; > 0 in contact [m]
delta_dot          ``penetration_rate``       ``d delta / dt = -n . v_rel`` [m/s]
k                  ``ContactLaw.k``           stiffness [N/m^e]
e                  ``ContactLaw.e``           force exponent (1.5: Hertz point contact) [-]
c                  ``ContactLaw.c``           Hunt-Crossley damping factor [s/m] (see below)
mu_s, mu_d         ``ContactLaw.mu_s/_d``     static / dynamic friction coefficients [-]
v_s, v_d           ``ContactLaw.v_s/_d``      static / dynamic transition slip speeds [m/s]
STEP               ``jaxcable.core.math.cubic_step``  the Appendix's STEP function
f_n                ``normal_force``           normal contact force, >= 0 [N]
f_tau tau          ``friction`` (3,)          tangential (friction) force on the cable [N]
n                  ``normal``                 unit normal from the hook axis to the cable axis
v                  ``slip_velocity`` (3,)     tangential velocity v_t, cable - hook [m/s]
(none)             ``u``, ``w``               closest-point parameters on hook / cable segment
(none)             ``onset_width``            smoothing width of contact onset [m]
=================  =========================  ================================================

Normal force (choice)
---------------------
``f_n = k rho(delta)^e * h(1 + c delta_dot)`` (Hunt-Crossley form), where

* ``rho`` is a C1 cubic ramp of width ``w_o = onset_width``: ``rho = 0`` for ``delta <= 0``,
  ``delta^2 (2 w_o - delta) / w_o^2`` for ``0 < delta < w_o`` and exactly ``delta`` beyond. The
  spring is therefore exactly the paper's ``k delta^e`` for ``delta >= w_o``, zero without
  contact, and its gradient is finite (zero) at onset. Static penetration under a load
  ``F >= k w_o^e`` is exact; below it the ramp is softer and over-penetrates by at most
  ``max_x x (1 - x/w_o)^2 = 4 w_o / 27`` (at ``delta = w_o / 3``). Measured in the tests.
* The spring force is the exact derivative of the potential
  ``U(delta) = k int_0^delta rho(s)^e ds`` (:meth:`ContactLaw.potential_energy`; closed form beyond
  ``w_o``, 32-point Gauss-Legendre on the ramp, exact to rounding for ``e = 1.5``), so a scene can
  close its energy budget: ``dU/dt = -elastic_power``.
* Damping is proportional to the elastic force (Hunt & Crossley 1975): it vanishes at onset and
  at separation, so there is no force jump at impact and no sticky pull when the bodies separate.
  ``h`` is the same cubic ramp of width ``damping_clip_width`` [-] on the dimensionless factor
  ``1 + c delta_dot``: ``f_n >= 0`` always, smoothly (``h(y) = y`` for ``y >= width``; the clip
  only acts when the separation speed exceeds ``(1 - width)/c``, which a free impact never reaches:
  its rebound speed stays below ``1/c``). In the paper's linear notation the damping coefficient
  is ``c_paper = c k delta^e`` [N s/m]: load-proportional.
* Why not the printed ``k delta^e + c delta_dot``: with a constant ``c`` the force jumps by
  ``c v_impact`` at first touch and pulls (is negative) at the end of a rebound; both need ad hoc
  fixes (the paper gives none) and the restitution then has no closed form. With Hunt-Crossley the
  restitution of a free impact at speed ``v0`` is exact and independent of mass, ``k``, ``e`` and
  the ramp: ``a - ln(1 + a) = -a eps - ln(1 - a eps)`` with ``a = c v0``
  (:func:`restitution_coefficient`; to first order ``eps = 1 - 2 a / 3``).

Friction (correction of the printed law)
----------------------------------------
The Appendix prints ``mu(v) = -sign(v) mu_d`` for ``|v| > v_d``,
``sign(v) STEP(|v|, v_d, mu_d, v_s, mu_s)`` for ``v_s <= |v| <= v_d`` and
``STEP(v, -v_s, -mu_s, v_s, mu_s)`` for ``|v| < v_s``, with ``f_tau = mu(v) f_n``. The signs are
inconsistent: the first branch opposes ``v``, the other two point along it (the third is odd and
positive for ``v > 0``), so the printed ``mu`` jumps from ``+mu_d`` to ``-mu_d`` at ``|v| = v_d``.
Re-derived as one odd law opposing the slip: ``f_t = -mu(|v_t|) f_n v_t / |v_t|`` with the
magnitude, for slip speed ``s >= 0``,

* ``s < v_s``:        ``mu = STEP(s, -v_s, -mu_s, v_s, mu_s) = mu_s x (3 - x^2) / 2``, ``x = s/v_s``
* ``v_s <= s``:       ``mu = STEP(s, v_d, mu_d, v_s, mu_s)`` (= ``mu_d`` for ``s >= v_d``).

The printed middle branch has its interval reversed (``t0 = v_d > t1 = v_s``); by the symmetry
``S(1 - eta) = 1 - S(eta)`` of the cubic it equals ``STEP(s, v_s, mu_s, v_d, mu_d)``, and
``cubic_step`` evaluates it as printed. ``mu(s)`` is C1 (continuous with zero slope at ``v_s`` and
``v_d``). The paper calls STEP "second-order continuous"; the cubic ``eta^2 (3 - 2 eta)`` is only C1
(its second derivative jumps by ``6 a / (t1 - t0)^2`` at the ends), kept as printed. Near zero slip
the law is a regularised stick: ``mu(s)/s -> 1.5 mu_s / v_s`` is a polynomial in ``s^2``, which
gives a direction that is gradient-safe at ``v_t = 0``; a tangential load below ``mu_s f_n`` is held
with a creep speed below ``v_s`` (no true sticking state).

Approximations (stated)
-----------------------
* One contact point per capsule pair: the closest points of the two axes. For (near-)parallel
  axes (``sin^2(angle) <= 1e-12``) the point is the middle of the overlap. Where the axes
  intersect (``gap = 0``, penetration ``r_hook + r_cable``: a contact already lost) the normal
  falls back to ``d_hook x d_cable`` (sign arbitrary), finite but not physical.
* Contact-point velocities are the linear interpolation of the segment-end velocities at fixed
  ``u, w``. This is exact for the material points of a rigid hook axis and of a linear cable
  element, and the resulting ``delta_dot`` is the exact time derivative of ``delta`` (the closest
  point is stationary in ``u, w``). It ignores the spin of a hook about its own axis (surface
  velocity ``omega x r n``) and, for ALE elements, the convective material velocity; callers that
  need these can use the returned ``point`` and ``force`` with their own mapping (e.g. a ``vjp``
  of the point's position to generalised forces).
* The force at the cable axis point is split to the two element nodes by the linear weights
  ``(1 - w), w`` and the opposite force on the hook axis point by ``(1 - u), u``. This preserves the
  force and its moment about the axis points; the friction couple ``gap x f_t`` between the two
  axis points (arm ``r_hook + r_cable - delta``) is not applied to the cable (it has no rotational
  degree of freedom). A rigid-body hook should take the moment of ``-force`` at ``point``.
* Adjacent cable capsules overlap at their shared node. :func:`pairwise_contacts` counts a contact
  whose cable point is clamped at an interior node only when the neighbouring element is clamped at
  the same node too, and then half from each (so a hook sliding across a node sees one contact,
  continuously). Zero-length interior elements and hook capsules that share an end (arm + barb
  joint) are not de-duplicated.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from jaxcable.core.math import cubic_step, safe_norm, safe_normalize
from jaxcable.core.validation import check_finite, check_positive, check_range
from jaxcable.core.validation import as_float_array, concrete as _concrete_float

__all__ = [
    "DEFAULT_EFFECTIVE_MASS",
    "DEFAULT_LOAD",
    "DEFAULT_PENETRATION",
    "CapsuleContact",
    "ContactLaw",
    "PairwiseContacts",
    "capsule_contact",
    "contact_power",
    "pairwise_contacts",
    "restitution_coefficient",
    "segment_segment_closest",
]


# ---------------------------------------------------------------------------------------------
# Default parameters. The paper gives none for the contact; each default is derived here.
# ---------------------------------------------------------------------------------------------

DEFAULT_LOAD = 3.0e5
"""Design normal load of one hook [N]: peak deceleration load ``m_r (1 + 4) g / 4`` of the
25 t stage at the 5 g limit shared by 4 hooks (Sec. II.B: 3.07e5 N), rounded."""

DEFAULT_PENETRATION = 5.0e-3
"""Penetration chosen at ``DEFAULT_LOAD`` [m]: a quarter of the 20 mm cable radius. Solid steel
crossed cylinders (radii 75 and 20 mm, E = 210 GPa) would give about 0.5 mm (Hertz); a stranded wire
rope flattens far more under a lateral load, and the softer penalty keeps the contact mode
(~3000 rad/s on a 10 kg mass) affordable for an explicit solver."""

DEFAULT_EFFECTIVE_MASS = 10.0
"""Effective mass of the contact mode used to size the damping [kg]: the reduced mass of a 45 kg
hook (Table 1, m_h) and the ~1.2 m of arresting cable (9.8 kg/m, Table 1) near the contact,
45 * 12 / 57 = 9.5 kg, rounded."""

_DEFAULT_K = DEFAULT_LOAD / DEFAULT_PENETRATION**1.5  # 8.485e8 N/m^1.5
# Critical damping of small oscillations about the design load: linear stiffness
# k_t = e F0 / delta0 = 9e7 N/m, c_crit = 2 sqrt(k_t m) = 6e4 N s/m = c F0  ->  c = 0.2 s/m.
_DEFAULT_C = (2.0 * np.sqrt(1.5 * DEFAULT_LOAD / DEFAULT_PENETRATION * DEFAULT_EFFECTIVE_MASS)
              / DEFAULT_LOAD)

# 32-point Gauss-Legendre rule on [0, 1] for the potential of the onset ramp.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(32)
_GL_T = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W

_PARALLEL_SIN2 = 1e-12
"""Axes with ``sin^2(angle) <= _PARALLEL_SIN2`` are treated as parallel (midpoint of overlap)."""






# ---------------------------------------------------------------------------------------------
# Private gradient-safe helpers
# ---------------------------------------------------------------------------------------------


def _cubic_ramp(x, width):
    """C1 ramp: 0 for x <= 0, ``x^2 (2 width - x) / width^2`` on (0, width), exactly x beyond.

    Unlike the softplus ``smooth_relu`` it is exactly zero without contact and exact past
    ``width``; it never exceeds ``max(x, 0)`` and is monotone (slope <= 4/3).
    """
    inside = x * x * (2.0 * width - x) / (width * width)
    return jnp.where(x <= 0.0, 0.0, jnp.where(x >= width, x, inside))


def _safe_pow(x, p):
    """``x^p`` for ``x >= 0`` with finite gradients in x and p at x = 0 (value 0 there)."""
    positive = x > 0.0
    x_safe = jnp.where(positive, x, 1.0)
    return jnp.where(positive, x_safe**p, 0.0)


def _dot(a, b):
    return jnp.sum(a * b, axis=-1)


def _fallback_normal(d1, d2):
    """A unit vector normal to both segment directions, for coincident axis points (gap = 0).

    The coordinate axis least aligned with the longer direction is picked by comparison with the
    ``argmin`` (not by indexing an identity matrix: under ``vmap`` that is a gather, and this
    function is evaluated for every pair although it is used only at gap = 0)."""
    longer = jnp.where(_dot(d1, d1) >= _dot(d2, d2), d1, d2)
    axis = (jnp.arange(3) == jnp.argmin(jnp.abs(longer))).astype(longer.dtype)
    perpendicular = safe_normalize(jnp.cross(longer, axis), jnp.array([0.0, 0.0, 1.0], longer.dtype))
    return safe_normalize(jnp.cross(d1, d2), perpendicular)


# ---------------------------------------------------------------------------------------------
# Geometry
# ---------------------------------------------------------------------------------------------


def segment_segment_closest(p0, p1, q0, q1):
    """Closest points of the segments ``p(u) = p0 + u (p1 - p0)`` and ``q(w) = q0 + w (q1 - q0)``.

    Args:
        p0, p1: ends of the first (hook) segment [m], shape (3,).
        q0, q1: ends of the second (cable) segment [m], shape (3,).

    Returns:
        ``(u, w, gap)``: parameters in [0, 1], shape (); ``gap = q(w) - p(u)`` [m], shape (3,).

    The convex problem on the unit square is solved in closed form (Ericson, Real-Time Collision
    Detection, 5.1.9): the unconstrained ``u`` is clamped, ``w`` follows and is clamped, and ``u`` is
    re-projected on the clamped ``w`` (which leaves an optimal ``u`` unchanged by the KKT
    conditions). Zero-length segments give ``u = 0`` / ``w = 0``; parallel axes give the middle of
    their overlap (or the nearest ends when they do not overlap). Every division has a guarded
    denominator, so values and gradients are finite for degenerate and parallel inputs.
    """
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e, b = _dot(d1, d1), _dot(d2, d2), _dot(d1, d2)
    c, f = _dot(d1, r), _dot(d2, r)
    finfo = jnp.finfo(jnp.result_type(a))
    tiny = finfo.eps**2 * (a + e + _dot(r, r)) + finfo.tiny  # only exact degeneracy is special
    p_degenerate = a <= tiny
    q_degenerate = e <= tiny
    a_safe = jnp.where(p_degenerate, 1.0, a)
    e_safe = jnp.where(q_degenerate, 1.0, e)
    denom = a * e - b * b  # = |d1 x d2|^2 >= 0
    parallel = denom <= _PARALLEL_SIN2 * a * e
    denom_safe = jnp.where(parallel, 1.0, denom)

    u_general = jnp.clip((b * f - c * e) / denom_safe, 0.0, 1.0)
    # Parallel: project q's ends on p's axis and take the middle of the overlap with [0, 1].
    u_q0, u_q1 = -c / a_safe, (b - c) / a_safe
    lo = jnp.maximum(0.0, jnp.minimum(u_q0, u_q1))
    hi = jnp.minimum(1.0, jnp.maximum(u_q0, u_q1))
    u_parallel = jnp.clip(0.5 * (lo + hi), 0.0, 1.0)
    u = jnp.where(parallel, u_parallel, u_general)
    u = jnp.where(p_degenerate, 0.0, u)

    w = jnp.where(q_degenerate, 0.0, jnp.clip((b * u + f) / e_safe, 0.0, 1.0))
    u = jnp.where(p_degenerate, 0.0, jnp.clip((b * w - c) / a_safe, 0.0, 1.0))
    gap = (q0 + w * d2) - (p0 + u * d1)
    return u, w, gap


# ---------------------------------------------------------------------------------------------
# Contact law
# ---------------------------------------------------------------------------------------------


class ContactLaw(eqx.Module):
    """Hertz-type normal force with Hunt-Crossley damping and Coulomb-STEP friction (Appendix).

    Every field is a scalar array (sweepable with ``vmap``, differentiable). Values are checked
    when concrete (not under ``jit``/``vmap``/``grad``). Defaults are derived in the module
    docstring and next to ``DEFAULT_LOAD``: the paper gives no contact parameters.
    """

    k: Array = eqx.field(default=_DEFAULT_K, converter=as_float_array)
    """stiffness [N/m^e], shape (); default 8.49e8: 3e5 N penetrates 5 mm at e = 1.5"""
    e: Array = eqx.field(default=1.5, converter=as_float_array)
    """force exponent [-], shape (), >= 1; 1.5 is Hertz point contact (crossed cylinders)"""
    c: Array = eqx.field(default=_DEFAULT_C, converter=as_float_array)
    """Hunt-Crossley damping factor [s/m], shape (); ``f_n = k rho^e (1 + c delta_dot)``. Default
    0.2: critical damping of a 10 kg mass about the 3e5 N design load (restitution 0.88 at a
    1 m/s impact, 0.59 at 5 m/s, 0.41 at 10 m/s)"""
    mu_s: Array = eqx.field(default=0.15, converter=as_float_array)
    """static friction coefficient [-], shape (); 0.15: lubricated steel on steel (wire rope
    dressing; dry steel on steel is ~0.5-0.8)"""
    mu_d: Array = eqx.field(default=0.10, converter=as_float_array)
    """dynamic friction coefficient [-], shape (); 0.10: lubricated steel on steel"""
    v_s: Array = eqx.field(default=0.01, converter=as_float_array)
    """slip speed at which ``mu`` reaches ``mu_s`` [m/s], shape ()"""
    v_d: Array = eqx.field(default=0.05, converter=as_float_array)
    """slip speed beyond which ``mu = mu_d`` [m/s], shape (), > v_s"""
    onset_width: Array = eqx.field(default=5.0e-4, converter=as_float_array)
    """width of the contact-onset ramp [m], shape (); the spring is exactly ``k delta^e`` past it.
    Default 0.5 mm = a tenth of the design penetration: static penetration is exact above
    ``k w^e`` = 9.5 kN and over-predicted by at most ``4 w / 27`` = 0.074 mm below"""
    damping_clip_width: Array = eqx.field(default=0.1, converter=as_float_array)
    """width of the smooth clip of ``1 + c delta_dot`` at zero [-], shape (), in (0, 1]"""

    def __check_init__(self):
        check_positive("ContactLaw.k", self.k)
        check_range("ContactLaw.e", self.e, 1.0, 5.0, inclusive=True, why="1: linear, 1.5: Hertz point contact")
        for name in ("c", "mu_s", "mu_d"):
            check_positive(f"ContactLaw.{name}", getattr(self, name), allow_zero=True)
        for name in ("mu_s", "mu_d"):
            check_range(f"ContactLaw.{name}", getattr(self, name), 0.0, 2.0, inclusive=True,
                        why="dry steel on steel: 0.5-0.8")  # fmt: skip
        for name in ("v_s", "v_d", "onset_width"):
            check_positive(f"ContactLaw.{name}", getattr(self, name))
        check_positive("ContactLaw.damping_clip_width", self.damping_clip_width)
        check_range("ContactLaw.damping_clip_width", self.damping_clip_width, 0.0, 1.0, inclusive=True)
        v_s, v_d = _concrete_float(self.v_s), _concrete_float(self.v_d)
        if v_s is not None and v_d is not None and np.any(v_s >= v_d):
            raise ValueError(
                f"ContactLaw.v_s = {self.v_s!r} m/s must be below ContactLaw.v_d = {self.v_d!r} m/s"
            )

    # --- normal ---------------------------------------------------------------------------

    def smoothed_penetration(self, penetration):
        """``rho(delta)``: the onset ramp of the penetration [m] (exactly delta past onset_width)."""
        return _cubic_ramp(penetration, self.onset_width)

    def elastic_force(self, penetration):
        """Spring part ``k rho(delta)^e`` [N], = dU/d(delta); zero for delta <= 0."""
        return self.k * _safe_pow(self.smoothed_penetration(penetration), self.e)

    def potential_energy(self, penetration):
        """``U(delta) = k int_0^delta rho(s)^e ds`` [J], whose derivative is :meth:`elastic_force`."""
        w, e = self.onset_width, self.e
        ramp_end = jnp.clip(penetration, 0.0, w)
        samples = _safe_pow(_cubic_ramp(ramp_end[..., None] * _GL_T, w[..., None]), e[..., None])
        on_ramp = ramp_end * jnp.sum(_GL_W * samples, axis=-1)
        beyond = jnp.maximum(penetration, w)
        past_ramp = (_safe_pow(beyond, e + 1.0) - _safe_pow(w, e + 1.0)) / (e + 1.0)
        return self.k * (on_ramp + past_ramp)

    def normal_force(self, penetration, penetration_rate):
        """``f_n = k rho(delta)^e h(1 + c delta_dot)`` [N], >= 0, continuous, zero for delta <= 0."""
        factor = _cubic_ramp(1.0 + self.c * penetration_rate, self.damping_clip_width)
        return self.elastic_force(penetration) * factor

    # --- friction -------------------------------------------------------------------------

    def friction_coefficient(self, slip_speed):
        """``mu(s)`` for slip speed ``s >= 0`` [-]: the Appendix's law with consistent signs."""
        stick = cubic_step(slip_speed, -self.v_s, -self.mu_s, self.v_s, self.mu_s)
        slide = cubic_step(slip_speed, self.v_d, self.mu_d, self.v_s, self.mu_s)
        return jnp.where(slip_speed < self.v_s, stick, slide)

    def friction_per_speed(self, slip_speed_sq):
        """``mu(s) / s`` [s/m] as a function of ``s^2``: finite and smooth at zero slip.

        Below ``v_s`` it is the polynomial ``mu_s (3 - x^2) / (2 v_s)``, ``x = s / v_s``.
        """
        v_s = self.v_s
        sliding = slip_speed_sq >= v_s * v_s
        s_safe = jnp.sqrt(jnp.where(sliding, slip_speed_sq, v_s * v_s))
        stick = self.mu_s * (3.0 - slip_speed_sq / (v_s * v_s)) / (2.0 * v_s)
        slide = cubic_step(s_safe, self.v_d, self.mu_d, v_s, self.mu_s) / s_safe
        return jnp.where(sliding, slide, stick)

    def friction_force(self, normal_force, slip_velocity):
        """``-mu(|v_t|) f_n v_t / |v_t|`` [N], shape (3,): opposes the slip, zero at zero slip."""
        ratio = self.friction_per_speed(_dot(slip_velocity, slip_velocity))
        return -(normal_force * ratio)[..., None] * slip_velocity


def contact_power(law: ContactLaw, penetration, penetration_rate, slip_speed):
    """Power of one contact's forces on the two bodies together [W].

    Returns:
        ``(elastic_power, dissipated_power)``: ``elastic_power = -f_el delta_dot = -dU/dt``;
        ``dissipated_power = damping + friction <= 0``, with damping ``-(f_n - f_el) delta_dot``
        (``h(1 + c delta_dot) - 1`` has the sign of ``delta_dot``) and friction
        ``-mu(s) f_n s``. Their sum is ``force . (v_cable - v_hook)`` at the contact point.
    """
    elastic = law.elastic_force(penetration)
    normal = law.normal_force(penetration, penetration_rate)
    damping_power = -(normal - elastic) * penetration_rate
    friction_power = -law.friction_coefficient(slip_speed) * normal * slip_speed
    return -elastic * penetration_rate, damping_power + friction_power


def restitution_coefficient(c, impact_speed, iterations: int = 100):
    """Exact restitution of a free Hunt-Crossley impact: ``eps`` in (0, 1] [-].

    With ``m delta_dd = -k rho(delta)^e (1 + c delta_dot)`` separate variables,
    ``v dv / (1 + c v) = -(k/m) rho^e d delta``; the right side integrates to zero over the
    contact, so ``G(v0) = G(-eps v0)`` with ``G(v) = v/c - ln(1 + c v)/c^2``, i.e. with ``a = c v0``:
    ``a - ln(1 + a) = -a eps - ln(1 - a eps)``. Independent of mass, ``k``, ``e`` and the onset ramp.
    Valid while the damping clip is inactive (``1 - a eps >= damping_clip_width``). Bisection.
    """
    a = jnp.asarray(c) * jnp.asarray(impact_speed)
    a_safe = jnp.where(a > 0.0, a, 1.0)
    target = a_safe - jnp.log1p(a_safe)

    def residual(eps):  # increasing in eps: -target at 0, +inf at eps = 1/a, > 0 at eps = 1
        return -a_safe * eps - jnp.log1p(-a_safe * eps) - target

    def body(_, bracket):
        lo, hi = bracket
        mid = 0.5 * (lo + hi)
        below = residual(mid) < 0.0
        return jnp.where(below, mid, lo), jnp.where(below, hi, mid)

    hi0 = jnp.minimum(1.0, 1.0 / a_safe) * (1.0 - 1e-15)
    lo, hi = jax.lax.fori_loop(0, iterations, body, (jnp.zeros_like(a_safe), hi0))
    return jnp.where(a > 0.0, 0.5 * (lo + hi), 1.0)


# ---------------------------------------------------------------------------------------------
# One contact pair
# ---------------------------------------------------------------------------------------------


class CapsuleContact(eqx.Module):
    """Contact of one hook capsule with one cable element (all fields of one pair)."""

    force_on_cable_nodes: Array
    """force on the element's two nodes, ``[(1 - w) F, w F]`` [N], shape (2, 3)"""
    force_on_hook_points: Array
    """force on the hook segment's two ends, ``[-(1 - u) F, -u F]`` [N], shape (2, 3)"""
    u: Array
    """closest-point parameter on the hook segment [-], shape ()"""
    w: Array
    """closest-point parameter on the cable element [-], shape ()"""
    point: Array
    """contact point, midway between the two surfaces along the normal [m], shape (3,)"""
    force: Array
    """total contact force on the cable ``F = f_n n + f_t`` (the hook gets ``-F``) [N], shape (3,)"""
    friction: Array
    """its tangential part ``f_t = -mu(|v_t|) f_n v_t / |v_t|`` [N], shape (3,)"""
    normal: Array
    """unit normal from the hook axis to the cable axis [-], shape (3,)"""
    penetration: Array
    """``delta = r_hook + r_cable - |gap|`` (> 0 in contact) [m], shape ()"""
    penetration_rate: Array
    """``d delta / dt`` [m/s], shape ()"""
    normal_force: Array
    """``f_n`` >= 0 [N], shape ()"""
    elastic_force: Array
    """spring part ``k rho(delta)^e`` of ``f_n`` [N], shape ()"""
    slip_speed: Array
    """``|v_t|``, tangential speed of the cable point relative to the hook point [m/s], shape ()"""
    potential_energy: Array
    """elastic energy ``U(delta)`` [J], shape ()"""
    elastic_power: Array
    """power of the spring part on both bodies, ``-dU/dt`` [W], shape ()"""
    dissipated_power: Array
    """power of damping + friction on both bodies, <= 0 [W], shape ()"""


def _check_vector(name, value):
    if jnp.shape(value) != (3,):
        raise ValueError(f"{name} must have shape (3,), got {jnp.shape(value)}")


def _capsule_contact(law, hook_p0, hook_p1, hook_radius, hook_v0, hook_v1,
                     cable_p0, cable_p1, cable_radius, cable_v0, cable_v1):
    u, w, gap = segment_segment_closest(hook_p0, hook_p1, cable_p0, cable_p1)
    normal = safe_normalize(gap, _fallback_normal(hook_p1 - hook_p0, cable_p1 - cable_p0))
    penetration = hook_radius + cable_radius - safe_norm(gap)

    v_rel = ((1.0 - w) * cable_v0 + w * cable_v1) - ((1.0 - u) * hook_v0 + u * hook_v1)
    normal_speed = _dot(normal, v_rel)
    penetration_rate = -normal_speed
    slip_velocity = v_rel - normal_speed * normal

    elastic = law.elastic_force(penetration)
    f_n = law.normal_force(penetration, penetration_rate)
    friction = law.friction_force(f_n, slip_velocity)
    force = f_n * normal + friction
    slip_speed = safe_norm(slip_velocity)
    elastic_power, dissipated_power = contact_power(law, penetration, penetration_rate, slip_speed)

    hook_point = hook_p0 + u * (hook_p1 - hook_p0)
    return CapsuleContact(
        force_on_cable_nodes=jnp.stack([(1.0 - w) * force, w * force]),
        force_on_hook_points=jnp.stack([-(1.0 - u) * force, -u * force]),
        u=u,
        w=w,
        point=hook_point + (hook_radius - 0.5 * penetration) * normal,
        force=force,
        friction=friction,
        normal=normal,
        penetration=penetration,
        penetration_rate=penetration_rate,
        normal_force=f_n,
        elastic_force=elastic,
        slip_speed=slip_speed,
        potential_energy=law.potential_energy(penetration),
        elastic_power=elastic_power,
        dissipated_power=dissipated_power,
    )


def capsule_contact(
    law: ContactLaw,
    hook_p0,
    hook_p1,
    hook_radius,
    hook_v0,
    hook_v1,
    cable_p0,
    cable_p1,
    cable_radius,
    cable_v0,
    cable_v1,
) -> CapsuleContact:
    """Contact force between one hook capsule and one cable element (capsule).

    Args:
        law: the :class:`ContactLaw`.
        hook_p0, hook_p1: ends of the hook capsule's axis [m], shape (3,).
        hook_radius: hook capsule radius [m], shape () (0.075 for the paper's 0.15 m arm).
        hook_v0, hook_v1: velocities of the hook axis ends [m/s], shape (3,).
        cable_p0, cable_p1: the cable element's nodes [m], shape (3,).
        cable_radius: cable radius [m], shape () (0.02 for the paper's cable).
        cable_v0, cable_v1: node velocities [m/s], shape (3,).

    Returns:
        :class:`CapsuleContact`. Contact-point velocities are linear interpolations of the end
        velocities at the closest-point parameters (see module docstring).
    """
    for name, value in (("hook_p0", hook_p0), ("hook_p1", hook_p1), ("hook_v0", hook_v0),
                        ("hook_v1", hook_v1), ("cable_p0", cable_p0), ("cable_p1", cable_p1),
                        ("cable_v0", cable_v0), ("cable_v1", cable_v1)):
        _check_vector(name, value)
    check_positive("hook_radius", hook_radius, allow_zero=True)
    check_positive("cable_radius", cable_radius, allow_zero=True)
    return _capsule_contact(law, hook_p0, hook_p1, hook_radius, hook_v0, hook_v1,
                            cable_p0, cable_p1, cable_radius, cable_v0, cable_v1)


# ---------------------------------------------------------------------------------------------
# All hooks x all cable elements
# ---------------------------------------------------------------------------------------------


class PairwiseContacts(eqx.Module):
    """Totals of all hook-capsule x cable-element contacts."""

    force_on_cable_nodes: Array
    """total contact force on each cable node [N], shape (N, 3)"""
    force_on_hook_points: Array
    """total contact force on each hook capsule's two ends [N], shape (H, 2, 3)"""
    hook_normal_force: Array
    """sum of the normal forces on each hook capsule [N], shape (H,) ("captured" when > 0)"""
    max_penetration: Array
    """largest signed penetration over all pairs [m], shape () (negative: smallest clearance)"""
    potential_energy: Array
    """total elastic contact energy [J], shape ()"""
    dissipated_power: Array
    """total damping + friction power, <= 0 [W], shape ()"""


def _node_sharing_weights(w):
    """Weights (H, E) that count a contact clamped at an interior node once (see module docstring).

    A contact whose cable point is an interior node is a true node contact only if the
    neighbouring element's closest point is that node as well; both then count one half. Otherwise
    the neighbour's interior contact covers it and it counts zero. Free cable ends count fully.
    """
    at_start, at_end = w <= 0.0, w >= 1.0
    n_elements = w.shape[-1]
    index = jnp.arange(n_elements)
    prev_at_end = jnp.concatenate([jnp.zeros_like(at_end[..., :1]), at_end[..., :-1]], axis=-1)
    next_at_start = jnp.concatenate([at_start[..., 1:], jnp.zeros_like(at_start[..., :1])], axis=-1)
    start_weight = jnp.where(index == 0, 1.0, jnp.where(prev_at_end, 0.5, 0.0))
    end_weight = jnp.where(index == n_elements - 1, 1.0, jnp.where(next_at_start, 0.5, 0.0))
    return jnp.where(at_start, start_weight, jnp.where(at_end, end_weight, 1.0))


def pairwise_contacts(
    law: ContactLaw,
    hook_segments,
    hook_radii,
    hook_velocities,
    cable_nodes,
    cable_velocities,
    cable_radius,
) -> PairwiseContacts:
    """All hook capsules against all elements of one cable, lifted with ``jax.vmap``; O(H N).

    Args:
        law: the :class:`ContactLaw`.
        hook_segments: hook capsule axes, ``[:, 0]`` and ``[:, 1]`` the ends [m], shape (H, 2, 3).
        hook_radii: hook capsule radii [m], shape (H,).
        hook_velocities: velocities of the capsule ends [m/s], shape (H, 2, 3).
        cable_nodes: cable node positions [m], shape (N, 3), N >= 2; element i joins nodes i, i+1.
        cable_velocities: node velocities [m/s], shape (N, 3).
        cable_radius: cable radius [m], shape ().

    Returns:
        :class:`PairwiseContacts`. Contacts at shared interior nodes are counted once.
    """
    hook_segments, hook_velocities = jnp.asarray(hook_segments), jnp.asarray(hook_velocities)
    hook_radii = jnp.asarray(hook_radii)
    cable_nodes, cable_velocities = jnp.asarray(cable_nodes), jnp.asarray(cable_velocities)
    if hook_segments.ndim != 3 or hook_segments.shape[1:] != (2, 3):
        raise ValueError(f"hook_segments must have shape (H, 2, 3), got {hook_segments.shape}")
    n_hooks = hook_segments.shape[0]
    if hook_velocities.shape != hook_segments.shape:
        raise ValueError(
            f"hook_velocities must have shape {hook_segments.shape}, got {hook_velocities.shape}")
    if hook_radii.shape != (n_hooks,):
        raise ValueError(f"hook_radii must have shape ({n_hooks},), got {hook_radii.shape}")
    if cable_nodes.ndim != 2 or cable_nodes.shape[1] != 3 or cable_nodes.shape[0] < 2:
        raise ValueError(f"cable_nodes must have shape (N, 3) with N >= 2, got {cable_nodes.shape}")
    if cable_velocities.shape != cable_nodes.shape:
        raise ValueError(
            f"cable_velocities must have shape {cable_nodes.shape}, got {cable_velocities.shape}")
    check_positive("hook_radii", hook_radii, allow_zero=True)
    check_positive("cable_radius", cable_radius, allow_zero=True)
    check_finite("cable_nodes", cable_nodes)
    check_finite("hook_segments", hook_segments)

    def one_pair(segment, radius, velocity, c0, c1, cv0, cv1):
        return _capsule_contact(law, segment[0], segment[1], radius, velocity[0], velocity[1],
                                c0, c1, cable_radius, cv0, cv1)

    over_elements = jax.vmap(one_pair, in_axes=(None, None, None, 0, 0, 0, 0))
    over_hooks = jax.vmap(over_elements, in_axes=(0, 0, 0, None, None, None, None))
    pairs = over_hooks(hook_segments, hook_radii, hook_velocities,
                       cable_nodes[:-1], cable_nodes[1:], cable_velocities[:-1], cable_velocities[1:])

    weight = _node_sharing_weights(pairs.w)  # (H, E)
    on_elements = jnp.sum(weight[..., None, None] * pairs.force_on_cable_nodes, axis=0)  # (E, 2, 3)
    on_nodes = (jnp.zeros_like(cable_nodes, dtype=on_elements.dtype)
                .at[:-1].add(on_elements[:, 0]).at[1:].add(on_elements[:, 1]))
    return PairwiseContacts(
        force_on_cable_nodes=on_nodes,
        force_on_hook_points=jnp.sum(weight[..., None, None] * pairs.force_on_hook_points, axis=1),
        hook_normal_force=jnp.sum(weight * pairs.normal_force, axis=1),
        max_penetration=jnp.max(pairs.penetration),
        potential_energy=jnp.sum(weight * pairs.potential_energy),
        dissipated_power=jnp.sum(weight * pairs.dissipated_power),
    )
