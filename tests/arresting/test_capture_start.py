"""The passive phase starts at first hook-cable contact: no hook inside its cable at t = 0."""

import numpy as np
import pytest

from jaxcable.arresting.cable_sets import _segment_distance, contact_free_drape_point
from jaxcable.arresting.layout import CaptureState
from jaxcable.arresting.passive import passive_landing_scene

CLEARANCE = 0.095  # hook radius 0.075 m + cable radius 0.02 m
# a hook: arm from the hinge (rocket shell) out along +x to the tip, barb up from the tip
HOOK = np.array([[0.0, 0.0, 0.0], [1.5, 0.0, 0.0], [1.5, 0.0, 0.6]])
THROAT = np.array([1.5 - CLEARANCE, 0.0, CLEARANCE])  # touching the arm (above it) and the barb


def _depth(pa, pb, c, hook=HOOK):
    caps = ((hook[0], hook[1]), (hook[1], hook[2]))
    return max(CLEARANCE - _segment_distance(h0, h1, q0, q1)[1] for h0, h1 in caps for q0, q1 in ((pa, c), (c, pb)))


@pytest.mark.parametrize("angle_deg", [0.0, 10.0, 25.0, 40.0])
def test_drape_point_leaves_the_cable_touching_not_inside_the_hook(angle_deg):
    """A straight cable through the throat square to the arm touches the arm and the barb; at an
    angle it passes within r cos(angle) of the barb's axis, i.e. enters it by r (1 - cos angle)
    (25 deg: 5.7 mm). The drape point moves it out, to touching, and no further than that depth
    allows (a few times the depth: it moves along the normals, not along the shortest path)."""
    a = np.deg2rad(angle_deg)
    d = np.array([np.sin(a), np.cos(a), 0.0])  # cable direction; square to the arm at 0 deg
    pa, pb = THROAT - 20.0 * d, THROAT + 25.0 * d
    before = _depth(pa, pb, THROAT)
    c = contact_free_drape_point(pa, pb, THROAT, HOOK, CLEARANCE)
    after = _depth(pa, pb, c)
    expected = CLEARANCE * (1.0 - np.cos(a))
    assert before == pytest.approx(expected, abs=1e-6)
    if before <= 5e-4:  # within the contact law's onset width: left as it is
        assert np.array_equal(c, THROAT)
    else:
        assert abs(after) < 1e-6  # touching, not inside
        assert np.linalg.norm(c - THROAT) < 5.0 * before


def test_tilted_rolled_capture_starts_without_a_contact_spike():
    """Section IV.A's deviated attitude (5 deg tilt about x and y, 25 deg roll) at the ale level: every
    span element of every cable is outside every hook capsule at t = 0 (it was 9-13 mm inside, a
    0.5-2.1 MN Hertz force and a 12.8 g spike shorter than 1 ms), and the design case's drape is
    the throat's, unchanged."""
    capture = CaptureState(theta_x_deg=5.0, theta_y_deg=5.0, theta_z_deg=25.0)
    # the capsule contact, whose elements could start inside a capsule (the node starts on the throat)
    scene = passive_landing_scene("ale", capture=capture, t_end_s=0.1, hook_contact="capsule", n_span_elements=32, n_fine=16)
    state = scene.initial_state()
    hooks = np.asarray(scene.hooks(state.rocket).positions)
    probe = scene.probe(0.0, state)
    assert np.all(np.asarray(probe["hook_normal_force_N"]) < 1.0)
    assert hooks.shape == (4, 3, 3)
