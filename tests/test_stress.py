"""Section forces and surface stresses (spacarpy.results.stress) against hand calculations."""
from __future__ import annotations

import math

import numpy as np
import pytest

from spacarpy.deck import load
from spacarpy.deck.visualization import CrossSection
from spacarpy.results import open_results, validate_file
from spacarpy.results.stress import section_forces, section_properties, surface_stress
from spacarpy.run import run_job

E, G = 2.0e11, 8.0e10


def cantilever_deck(tmp_path, section: str, dims: tuple, load: str, n: int = 8,
                    length: float = 1.0) -> str:
    """A straight cantilever along x, clamped at node 1, loaded at the tip node 3."""
    if section == "RECT":
        w, t = dims
        area, iy, iz = w * t, w * t**3 / 12, t * w**3 / 12
        j = iy + iz
    else:
        (d,) = dims
        area, iy = math.pi * d**2 / 4, math.pi * d**4 / 64
        iz, j = iy, 2 * iy
    text = f"""
X 1 0 0 0
BEAMS 1  1 2 3 4  {n}  0 1 0
X 3 {length} 0 0
DYNE 1:{n} 1:6
FIX 1
FIX 2
END
HALT
ESTIFF 1:{n} {E * area} {G * j} {E * iy} {E * iz}
{load}
ITERSTEP 20 1 1e-12
END
END

VISUALIZATION
BEAMPROPS 1:{n}
CROSSTYPE {section}
CROSSDIM {' '.join(str(v) for v in dims)}
"""
    path = tmp_path / "cantilever.dat"
    path.write_text(text)
    return str(path)


def run(tmp_path, *args, **kw):
    job = load(cantilever_deck(tmp_path, *args, **kw))
    out = tmp_path / "cantilever.h5"
    run_job(job, out)
    assert validate_file(out, require_complete=True) == []
    return open_results(out)


def test_section_properties_match_the_deck_cross_sections():
    rect, circ = CrossSection("RECT", (0.03, 0.01)), CrossSection("CIRC", (0.02,))
    props = section_properties(["RECT", "CIRC", ""], [[0.03, 0.01], [0.02, np.nan],
                                                      [np.nan, np.nan]])
    for i, cs in enumerate((rect, circ)):
        assert props.area[i] == pytest.approx(cs.area, rel=1e-15)
        np.testing.assert_allclose(props.second_moment[i], cs.second_moments, rtol=1e-15)
        np.testing.assert_allclose(props.extreme_fibre[i], cs.extreme_fibre, rtol=1e-15)
    assert props.known.tolist() == [True, True, False]
    assert np.isnan(props.torsion_modulus[2])
    assert props.torsion_modulus[1] == pytest.approx(math.pi * 0.02**3 / 16, rel=1e-15)


@pytest.mark.parametrize("ratio, alpha", [(1.0, 0.208), (1.5, 0.231), (2.0, 0.246),
                                          (3.0, 0.267), (4.0, 0.282), (10.0, 0.312)])
def test_rectangle_torsion_follows_saint_venant(ratio, alpha):
    # tau_max = T / (alpha b c^2), alpha from Timoshenko & Goodier's table (3 digits)
    b, c = 0.01 * ratio, 0.01
    for w, t in ((b, c), (c, b)):            # either side may be the long one
        wt = section_properties(["RECT"], [[w, t]]).torsion_modulus[0]
        assert wt / (b * c**2) == pytest.approx(alpha, abs=6e-4)
    strip = section_properties(["RECT"], [[1.0, 1e-4]]).torsion_modulus[0]
    assert strip / (1.0 * 1e-8) == pytest.approx(1 / 3, rel=1e-3)


def test_combined_stresses_by_hand():
    w, t, l0 = 0.04, 0.02, 0.5
    props = section_properties(["RECT", "CIRC"], [[w, t], [0.03, np.nan]])
    sigma = np.array([[1000.0, 40.0, 10.0, -30.0, 20.0, 5.0],
                      [-500.0, 0.0, 8.0, 2.0, -6.0, 4.0]])
    normal, mises = surface_stress(sigma, [l0, l0], props)
    f = section_forces(sigma, [l0, l0])
    np.testing.assert_allclose(f[0], [1000.0, 20.0, 5.0, -15.0, 10.0, 2.5])
    iy, iz = w * t**3 / 12, t * w**3 / 12
    end_q = 1000 / (w * t) + 15.0 * (t / 2) / iy + 2.5 * (w / 2) / iz
    end_p = 1000 / (w * t) + 5.0 * (t / 2) / iy + 10.0 * (w / 2) / iz
    assert normal[0] == pytest.approx(max(end_p, end_q), rel=1e-14)
    tau = 20.0 / props.torsion_modulus[0]
    assert mises[0] == pytest.approx(math.sqrt(max(end_p, end_q)**2 + 3 * tau**2), rel=1e-14)
    d = 0.03
    m_p, m_q = math.hypot(4.0, -3.0), math.hypot(1.0, 2.0)
    expected = 500 / (math.pi * d**2 / 4) + max(m_p, m_q) * 32 / (math.pi * d**3)
    assert normal[1] == pytest.approx(expected, rel=1e-14) and mises[1] == normal[1]


@pytest.mark.parametrize("section, dims", [("RECT", (0.02, 0.01)), ("CIRC", (0.015,))])
def test_cantilever_tip_force_root_stress_is_F_L_c_over_I(tmp_path, section, dims):
    force, length = 2.0, 1.0           # small: linear response
    res = run(tmp_path, section, dims, f"DELXF 3 0 {force} 0", length=length)
    s = res.static
    if section == "RECT":
        w, t = dims
        c, iz = w / 2, t * w**3 / 12
    else:
        c, iz = dims[0] / 2, math.pi * dims[0]**4 / 64
    root = force * length * c / iz
    sig = s.max_normal_stress(step=-1)
    assert sig[0] == pytest.approx(root, rel=2e-4)
    assert np.all(np.diff(sig) < 0)              # decreasing towards the tip
    np.testing.assert_allclose(s.max_von_mises_stress(step=-1), sig, rtol=1e-6)
    # section forces: Mz = F (L - x) at the element ends, everything else ~ 0
    f = s.section_forces(step=-1)
    x = res.model.position_x0[res.model.element_position_rows][:, :, 0]
    np.testing.assert_allclose(f[:, 4], force * (length - x[:, 0]), rtol=2e-4, atol=1e-9)
    np.testing.assert_allclose(f[:, 5], force * (length - x[:, 1]), rtol=2e-4, atol=1e-3)
    assert np.abs(f[:, [1, 2, 3]]).max() < 1e-6 * force * length
    # the elastic energy is the work of the force, F v / 2 (linear response)
    v = s.displacement(node=3, step=-1)[1]
    assert s.total_strain_energy(step=-1) == pytest.approx(force * v / 2, rel=1e-4)


def test_circular_shaft_in_torsion(tmp_path):
    torque, d = 5.0, 0.02
    res = run(tmp_path, "CIRC", (d,), f"DELXF 4 {torque} 0 0")
    tau = 16 * torque / (math.pi * d**3)
    s = res.static
    np.testing.assert_allclose(s.section_forces(step=-1)[:, 1], torque, rtol=1e-6)
    np.testing.assert_allclose(s.max_normal_stress(step=-1), 0.0, atol=1e-6 * tau)
    np.testing.assert_allclose(s.max_von_mises_stress(step=-1), math.sqrt(3) * tau, rtol=1e-6)


def test_no_cross_section_means_no_stress_datasets(tmp_path):
    from spacarpy.results import ResultsQueryError
    deck = cantilever_deck(tmp_path, "RECT", (0.02, 0.01), "DELXF 3 0 1 0")
    text = open(deck).read().split("VISUALIZATION")[0]
    open(deck, "w").write(text)
    out = tmp_path / "plain.h5"
    run_job(load(deck), out)
    res = open_results(out)
    assert not res.static.has_stress
    with pytest.raises(ResultsQueryError, match="no element of this model has a known "
                                                "cross-section"):
        res.static.max_normal_stress()
