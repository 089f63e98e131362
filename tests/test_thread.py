"""ISO thread tables and profile geometry (pure functions, no gmsh): docs/design.md numbers, flank and root geometry,
the nut bore with its countersinks, flanks that touch while the free flanks are open, bad sizes."""

import math

import numpy as np
import pytest

from frictionid.builders.thread import (COARSE_PITCH, SQRT3, bolt_load_flank_y, bolt_profile, engaged_flanks,
                                        first_tooth_window, nut_bore, nut_load_flank_y, thread_size,
                                        upper_envelope)
from frictionid.errors import InputError

SIZES = list(COARSE_PITCH)


def test_m20_matches_bolt_md():
    """docs/design.md table (M20 x 2.5), quoted to its printed digits."""
    s = thread_size("M20")
    assert s.P == 2.5 and s.d == 20.0
    assert s.H == pytest.approx(2.16506, abs=1e-5)
    assert s.d2 == pytest.approx(18.3762, abs=1e-4)
    assert s.d1 == pytest.approx(17.2937, abs=1e-4)
    assert s.d3 == pytest.approx(16.9328, abs=1e-4)
    assert s.root_radius == pytest.approx(0.3608, abs=1e-4)
    assert (s.d - s.d1) / 2 == pytest.approx(1.3532, abs=1e-4)          # engagement depth H1
    assert s.stress_area == pytest.approx(244.8, abs=0.05)
    assert s.es == pytest.approx(-0.042, abs=1e-12)
    assert (s.head_k, s.head_s, s.nut_m, s.nut_s, s.nut_dw) == (12.5, 30.0, 18.0, 30.0, 27.7)
    assert s.da == pytest.approx(21.0) and s.hex_radius == pytest.approx(15.75, abs=2e-3)
    assert s.thread_length(120.0) == 46.0 and s.hole == 22.0


@pytest.mark.parametrize("name", SIZES)
def test_iso_68_formulas_and_tables_for_every_size(name):
    s = thread_size(name)
    assert s.d2 == pytest.approx(s.d - 0.649519 * s.P, abs=1e-5)
    assert s.d1 == pytest.approx(s.d - 1.082532 * s.P, abs=1e-5)
    assert s.d3 == pytest.approx(s.d - 1.226869 * s.P, abs=1e-5)
    assert s.root_radius == pytest.approx(0.144338 * s.P, abs=3e-6)       # 6-digit coefficient times P <= 4
    # ISO 965-1 tabulates es = -(15 + 11 P) um rounded to whole um (M20: 42.5 -> 42)
    assert -s.es * 1000 == pytest.approx(15 + 11 * s.P, abs=1.5)
    assert s.da_range[0] <= s.da <= s.da_range[1]
    assert s.d < s.hole < s.nut_dw < s.nut_s


def test_unknown_size_names_the_key():
    with pytest.raises(InputError, match=r"`size` = 'M21' has no tabulated dimensions; expected one of M6, M8"):
        thread_size("M21")
    with pytest.raises(InputError, match="`size`"):
        thread_size(20)


def _tangent(segment, at_start: bool):
    """Unit tangent (direction of travel) of a profile segment at its start or end."""
    if segment.centre is None:
        t = np.subtract(segment.b, segment.a)
        return t / np.linalg.norm(t)
    p = np.asarray(segment.a if at_start else segment.b) - segment.centre
    t = np.array([-p[1], p[0]])                      # perpendicular to the radius ...
    other = np.asarray(segment.b if at_start else segment.a) - (segment.a if at_start else segment.b)
    t = t if np.dot(t, other) * (1 if at_start else -1) > 0 else -t   # ... pointing along the arc
    return t / np.linalg.norm(t)


def test_bolt_profile_flanks_roots_and_crests():
    s, shift = thread_size("M20"), 0.021
    profile = bolt_profile(s, 100.0, 110.0, 101.25, shift)
    assert profile[0].a[1] == pytest.approx(100.0) and profile[-1].b[1] == pytest.approx(110.0)
    for prev, nxt in zip(profile[:-1], profile[1:]):
        assert np.allclose(prev.b, nxt.a, atol=1e-12)                            # continuous outline
        if not (prev.a[1] == 100.0 or nxt.b[1] == 110.0):
            # smooth where an arc meets a flank (root rounding tangent to both flanks)
            if prev.centre is not None or nxt.centre is not None:
                assert np.allclose(_tangent(prev, False), _tangent(nxt, True), atol=1e-9)
    full = [seg for seg in profile if 100.0 < min(seg.a[1], seg.b[1]) and max(seg.a[1], seg.b[1]) < 110.0]
    for seg in full:
        (ra, ya), (rb, yb) = seg.a, seg.b
        if seg.role in ("load", "free"):
            assert abs((yb - ya) / (rb - ra)) == pytest.approx(1 / SQRT3, rel=1e-12)   # 30 deg from radial
            assert min(ra, rb) == pytest.approx(s.d1 / 2 - shift) and max(ra, rb) == pytest.approx(s.d / 2 - shift)
        if seg.role == "crest":
            assert ra == rb == pytest.approx(s.d / 2 - shift) and abs(yb - ya) == pytest.approx(s.P / 8)
        if seg.role == "root":
            rc, yc = seg.centre
            assert math.dist(seg.a, seg.centre) == pytest.approx(s.root_radius, rel=1e-12)
            assert rc - s.root_radius == pytest.approx(s.d3 / 2 - shift, abs=1e-12)    # bottom at d3/2
    load = [seg for seg in full if seg.role == "load"]
    assert all(bolt_load_flank_y(s, 101.25 + seg.tooth * s.P, shift, seg.a[0]) == pytest.approx(seg.a[1])
               for seg in load)


def test_upper_envelope_of_two_lines_and_a_step():
    a = np.array([[0.0, 0.0], [2.0, 2.0]])                 # r = y
    b = np.array([[2.0, 0.0], [0.0, 2.0]])                 # r = 2 - y
    env = upper_envelope([a, b], 0.0, 2.0)
    np.testing.assert_allclose(env, [[2.0, 0.0], [1.0, 1.0], [2.0, 2.0]], atol=1e-12)


def m20_bore(engaged=18.0):
    s, shift = thread_size("M20"), 0.021
    nut_phase = 103.5 + shift / SQRT3
    return s, shift, nut_phase, nut_bore(s, 94.5, 112.5, nut_phase, engaged)


def test_nut_bore_countersinks_crest_and_root():
    s, shift, nut_phase, bore = m20_bore()
    assert tuple(bore[0]) == pytest.approx((10.5, 94.5)) and tuple(bore[-1]) == pytest.approx((10.5, 112.5))
    r_root = s.d / 2 + s.H / 16
    assert bore[:, 0].min() == pytest.approx(s.d1 / 2) and bore[1:-1, 0].max() == pytest.approx(r_root)
    # first piece: the 120 deg countersink, 30 deg from the face (the free-flank slope)
    (r0, y0), (r1, y1) = bore[:2]
    assert (y1 - y0) / (r0 - r1) == pytest.approx(1 / SQRT3)
    crests = np.flatnonzero(np.isclose(bore[:-1, 0], s.d1 / 2) & np.isclose(bore[1:, 0], s.d1 / 2))
    assert len(crests) == 7
    np.testing.assert_allclose(bore[crests + 1, 1] - bore[crests, 1], s.P / 4)          # nut crest flat P/4


def test_load_flanks_touch_and_free_flanks_open_by_es_over_sqrt3():
    s, shift, nut_phase, bore = m20_bore()
    bolt_phase = 104.75
    flanks = engaged_flanks(s, bore, nut_phase, bolt_phase, shift, 74.0, 120.0)
    assert [f.index for f in flanks] == list(range(1, 8))
    r = np.linspace(s.d1 / 2, s.d / 2 - shift, 7)
    for f in flanks:
        assert f.r_contact == pytest.approx((s.d1 / 2, s.d / 2 - shift))
        np.testing.assert_allclose(bolt_load_flank_y(s, f.z_bolt, shift, r), nut_load_flank_y(s, f.z_nut, r),
                                   atol=1e-12)
        # free flanks: the bolt's above its tooth, the nut's below the next nut tooth, 0.0242 mm apart axially
        bolt_free = f.z_bolt + (s.d / 2 + s.H / 8 - shift - r) / SQRT3
        nut_free = f.z_nut + s.P - (r - (s.d / 2 - 7 * s.H / 8)) / SQRT3
        np.testing.assert_allclose(nut_free - bolt_free, 0.042 / SQRT3, atol=1e-12)
    # the default set-up: nut moved by 0.0123; exact touching with the rounded |es| = 0.042 needs 0.021 / sqrt(3)
    assert flanks[0].z_nut - (flanks[0].z_bolt - s.P / 2) == pytest.approx(0.012124, abs=1e-6)


def test_relieved_bore_engages_fewer_flanks():
    s, shift, nut_phase, bore = m20_bore(engaged=9.0)
    flanks = engaged_flanks(s, bore, nut_phase, 104.75, shift, 74.0, 120.0)
    assert len(flanks) == 3 and bore[-2, 0] == pytest.approx(s.d / 2 + s.H / 16)
    assert max(f.z_bolt for f in flanks) < 94.5 + 9.0


def test_a_cut_just_past_a_corner_leaves_no_sliver():
    s, shift = thread_size("M20"), 0.021
    corner = 101.25 - s.P / 16                                             # crest corner of the tooth at 101.25
    profile = bolt_profile(s, 100.0, corner + 1e-4, 101.25, shift)
    assert profile[-1].role == "load" and profile[-1].b[1] == pytest.approx(corner, abs=1e-12)
    assert min(math.dist(seg.a, seg.b) for seg in profile) > s.P / 50


@pytest.mark.parametrize("offset, n_flanks, first_width", [(0.0, 7, 1.0), (0.2, 7, 1.0), (0.8, 7, 0.30)])
def test_first_tooth_window_keeps_countersink_off_the_load_flanks(offset, n_flanks, first_width):
    """Nut teeth with the first complete tooth at z_min + offset: inside the window (width P/8 + 2 shift/sqrt 3
    = 0.337 mm for M20) no flank is cut; beyond it the tooth below shows a part-width load flank."""
    s, shift = thread_size("M20"), 0.021
    z_min, z_max = first_tooth_window(s, 94.5, shift)
    assert z_max - z_min == pytest.approx(s.P / 8 + 2 * shift / SQRT3)
    phase = z_min + offset
    bore = nut_bore(s, 94.5, 112.5, phase, 18.0)
    flanks = engaged_flanks(s, bore, phase, phase + s.P / 2 - shift / SQRT3, shift, 74.0, 120.0)
    width = [(f.r_contact[1] - f.r_contact[0]) / (s.d / 2 - shift - s.d1 / 2) for f in flanks]
    assert len(flanks) == n_flanks and width[0] == pytest.approx(first_width, abs=0.01)
    assert np.allclose(width[1:], 1.0)
