"""The SAE J211/1 CFC filter (jaxcable/core/filters.py) against closed forms: J211's coefficients,
the zero-phase gain of the forward-backward pair at any frequency, the 3 dB frequency of the classes,
DC and step responses, records that end early, gradients, vmap, bad input."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxcable.core.filters import (
    CFC_3DB_FACTOR,
    cfc_filter,
    cfc_gain,
    cfc_max_spacing_s,
    cfc_recommended_spacing_s,
    hold_last_finite,
    j211_coefficients,
)

DT = 1e-3  # the scenes' saved spacing [s]


def _reference_j211(x, dt, cfc):
    """J211/1 Appendix C as printed, in plain Python, each pass started in the steady state of its
    first input sample (the forward pass at x[0], the backward pass at the last forward output)."""
    wd = 2.0 * np.pi * cfc * 2.0775
    wa = np.sin(wd * dt / 2.0) / np.cos(wd * dt / 2.0)
    d = 1.0 + np.sqrt(2.0) * wa + wa**2
    a0 = wa**2 / d
    a1, a2 = 2.0 * a0, a0
    b1 = -2.0 * (wa**2 - 1.0) / d
    b2 = (-1.0 + np.sqrt(2.0) * wa - wa**2) / d

    def one(v):
        y = np.empty_like(v)
        x1 = x2 = y1 = y2 = v[0]
        for i, xi in enumerate(v):
            y[i] = a0 * xi + a1 * x1 + a2 * x2 + b1 * y1 + b2 * y2
            x2, x1, y2, y1 = x1, xi, y1, y[i]
        return y

    return one(one(np.asarray(x, float))[::-1])[::-1]


def test_coefficients_and_recursion_are_j211s():
    rng = np.random.default_rng(0)
    x = rng.normal(size=300)
    for cfc in (60.0, 180.0):
        np.testing.assert_allclose(np.asarray(cfc_filter(x, DT / 4, cfc)), _reference_j211(x, DT / 4, cfc), atol=1e-12)
    a0, a1, a2, b1, b2 = (float(c) for c in j211_coefficients(60.0, DT))
    # the bilinear transform's DC gain (a0 + a1 + a2) / (1 - b1 - b2) is one
    assert (a0 + a1 + a2) / (1.0 - b1 - b2) == pytest.approx(1.0, rel=1e-14)
    assert a1 == 2 * a0 and a2 == a0


@pytest.mark.parametrize("freq_hz", [5.0, 40.0, 100.0, 124.65, 200.0])
def test_sine_comes_out_scaled_by_the_closed_form_gain_with_zero_phase(freq_hz):
    """A sine through the forward-backward pair: far from the ends, exactly ``G(f) sin`` with
    ``G = 1 / (1 + (tan(pi f T) / tan(pi 2.0775 CFC T))^4)`` (real: no phase shift). At the design
    frequency 2.0775 CFC = 124.65 Hz, G = 1/2 exactly; at 5 Hz (the cable-counterweight mode)
    G = 1 - 2e-6."""
    t = np.arange(6000) * DT
    x = np.sin(2 * np.pi * freq_hz * t)
    y = np.asarray(cfc_filter(x, DT, 60.0))
    g = float(cfc_gain(freq_hz, 60.0, DT))
    mid = slice(1500, 4500)
    np.testing.assert_allclose(y[mid], g * x[mid], atol=1e-10)
    if freq_hz == 124.65:
        assert g == pytest.approx(0.5, abs=1e-12)


def test_3db_frequency_is_the_classes_F_H():
    """The -3 dB frequency (G = 1/sqrt 2) is F_H = 1.667 CFC in the analog limit (J211's 100, 300,
    1000, 1650 Hz for CFC 60, 180, 600, 1000), and near it on a fine grid."""
    assert CFC_3DB_FACTOR == pytest.approx(5.0 / 3.0, rel=1e-4)
    for cfc, f_h in ((60.0, 100.0), (180.0, 300.0), (600.0, 1000.0), (1000.0, 1650.0)):
        dt = 1e-6
        assert float(cfc_gain(f_h, cfc, dt)) == pytest.approx(2**-0.5, abs=0.01 if cfc < 1000 else 0.02), cfc
    # J211's sample-rate guidance: 10 samples per period of F_H: 1 ms for CFC 60 (the scenes' grid)
    assert cfc_recommended_spacing_s(60.0) == pytest.approx(1e-3, rel=1e-3)
    assert cfc_max_spacing_s(60.0) == pytest.approx(1.0 / (2 * 2.0775 * 60.0))


def test_constant_passes_unchanged_and_a_step_settles():
    """DC gain 1: a constant is returned as it is (both passes start in their steady state). A unit
    step settles to 1 on both sides, with the zero-phase 4-pole Butterworth's symmetric ringing
    (3.8% over, 3.8% under) and its midpoint at the step."""
    const = np.asarray(cfc_filter(np.full(200, 3.7), DT, 60.0))
    np.testing.assert_allclose(const, 3.7, rtol=1e-14)
    t = np.arange(1000) * DT
    step = np.where(t >= 0.5, 1.0, 0.0)
    y = np.asarray(cfc_filter(step, DT, 60.0))
    assert abs(y[-1] - 1.0) < 1e-9 and abs(y[0]) < 1e-9
    assert 0.03 < y.max() - 1.0 < 0.045 and 0.03 < -y.min() < 0.045
    assert y.max() - 1.0 == pytest.approx(-y.min(), rel=1e-6)  # zero phase: odd-symmetric about the step
    assert 0.3 < y[500] < 0.7


def test_initial_prepends_the_signal_before_the_record():
    """``initial`` is the signal before the record: a record that starts at 1 after 0 is filtered as
    the step inside a longer record is."""
    t = np.arange(600) * DT
    step = np.where(t >= 0.3, 1.0, 0.0)
    full = np.asarray(cfc_filter(step, DT, 60.0))
    tail = np.asarray(cfc_filter(step[300:], DT, 60.0, initial=0.0))
    np.testing.assert_allclose(tail, full[300:], atol=1e-6)
    assert tail.max() > 1.03  # the step's overshoot is there
    np.testing.assert_allclose(np.asarray(cfc_filter(step[300:], DT, 60.0)), 1.0, rtol=1e-14)  # default: none


def test_a_record_that_ends_early_holds_its_last_finite_sample():
    """Saved samples after an early end are inf: they are replaced by the last finite sample (or
    masked by ``valid``), so no inf/NaN reaches the output; the filter of a record that ends early
    equals the filter of the same record continued by its last value."""
    x = np.sin(np.arange(400) * 0.05)
    x_inf = x.copy()
    x_inf[250:] = np.inf
    held = x.copy()
    held[250:] = x[249]
    np.testing.assert_array_equal(np.asarray(hold_last_finite(x_inf)), held)
    y = np.asarray(cfc_filter(x_inf, DT, 60.0))
    assert np.all(np.isfinite(y))
    np.testing.assert_allclose(y, np.asarray(cfc_filter(held, DT, 60.0)), atol=1e-14)
    valid = np.arange(400) < 250
    np.testing.assert_allclose(np.asarray(cfc_filter(x, DT, 60.0, valid=valid)), y, atol=1e-14)
    # (n, 3) records: each column on its own; a leading bad sample becomes 0
    v = np.stack([x_inf, 2 * x_inf, -x_inf], axis=1)
    v[0, 1] = np.nan
    out = np.asarray(hold_last_finite(v))
    assert np.all(np.isfinite(out)) and out[0, 1] == 0.0 and out[300, 2] == -x[249]


def test_gradient_is_finite_and_matches_central_differences():
    """d(max of the filtered record)/d(signal, spacing), through the scans, is finite with inf samples
    after an early end (their cotangent is exactly zero), and matches central differences."""
    t = np.arange(300) * DT
    x = np.r_[np.sin(2 * np.pi * 8.0 * t[:200]) + 0.3 * np.sin(2 * np.pi * 150.0 * t[:200]), np.full(100, np.inf)]

    def peak(x, dt):
        return jnp.max(cfc_filter(x, dt, 60.0, valid=jnp.isfinite(x)))

    gx, gdt = jax.grad(peak, argnums=(0, 1))(jnp.asarray(x), DT)
    assert np.all(np.isfinite(gx)) and np.isfinite(gdt)
    assert np.all(np.asarray(gx)[200:] == 0.0)
    assert np.sum(np.asarray(gx)) == pytest.approx(1.0, rel=1e-10)  # DC gain one: shifting x shifts the max
    h = 1e-7
    fd = (float(peak(x, DT + h)) - float(peak(x, DT - h))) / (2 * h)
    assert float(gdt) == pytest.approx(fd, rel=1e-5)
    e = np.zeros(300)
    e[120] = 1e-6
    fd_x = (float(peak(x + e, DT)) - float(peak(x - e, DT))) / 2e-6
    assert float(gx[120]) == pytest.approx(fd_x, rel=1e-5, abs=1e-9)


def test_vmaps_over_records():
    x = np.random.default_rng(1).normal(size=(4, 250))
    batched = np.asarray(jax.vmap(lambda r: cfc_filter(r, DT, 60.0))(x))
    for i in range(4):
        np.testing.assert_allclose(batched[i], np.asarray(cfc_filter(x[i], DT, 60.0)), atol=1e-14)


def test_bad_input_gets_clear_errors():
    for bad in (0.0, -60.0, float("nan"), float("inf")):
        with pytest.raises(ValueError, match="cfc_hz"):
            cfc_filter(np.ones(10), DT, bad)
    for bad in (0.0, -1e-3):
        with pytest.raises(ValueError, match="dt_s"):
            cfc_filter(np.ones(10), bad, 60.0)
    # CFC 60's design frequency 124.65 Hz must stay below the Nyquist frequency: dt < 4.01 ms
    with pytest.raises(ValueError, match="dt_s must be below 0.00401"):
        cfc_filter(np.ones(10), 5e-3, 60.0)
    with pytest.raises(ValueError, match="x must be a record"):
        cfc_filter(np.ones(()), DT, 60.0)
