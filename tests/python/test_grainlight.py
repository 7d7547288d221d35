"""pytest suite of the grainlight Python module (examples/python/grainlight_module.cpp).

Run: PYTHONPATH=build/rel/python /usr/bin/python3 -m pytest tests/python  (ctest entry `python`).
Reference values: tests/data/mie_reference.md (Wiscombe's MIEV0 test problems, NCAR TN-140, and
Bohren & Huffman 1983 App. A), parsed from that file; closed forms named at each test.
"""

import math
import os
import re

import numpy as np
import pytest

import grainlight

DATA = os.environ.get("GRAINLIGHT_TEST_DATA_DIR",
                      os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data"))


def miev0_cases():
    """[(m in the n - ik convention of the table, x, qext, qsca, gqsca, {angle: (S1, S2)})]."""
    with open(os.path.join(DATA, "mie_reference.md"), encoding="utf-8") as f:
        text = f.read()
    cases = []
    for block in re.split(r"^## ", text, flags=re.M)[1:]:
        head = re.match(r"m = ([0-9.]+)([-+][0-9.e-]+)i, x = ([0-9.]+)", block)
        if not head:
            continue
        m = complex(float(head.group(1)), float(head.group(2)))
        q = re.search(r"Qext = ([0-9.e+-]+), Qsca = ([0-9.e+-]+), g\*Qsca = ([0-9.e+-]+)", block)
        rows = {}
        for line in block.splitlines():
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if len(cells) == 5 and re.fullmatch(r"[0-9]+", cells[0]):
                v = [float(c) for c in cells[1:]]
                rows[int(cells[0])] = (complex(v[0], v[1]), complex(v[2], v[3]))
        cases.append((m, float(head.group(3)), float(q.group(1)), float(q.group(2)), float(q.group(3)), rows))
    return cases


CASES = miev0_cases()


def test_reference_file_parsed():
    # Five tabulated MIEV0 problems with seven angles each (a parse failure must not pass silently).
    assert len(CASES) == 5
    assert all(len(c[5]) == 7 for c in CASES)


@pytest.mark.parametrize("case", CASES, ids=lambda c: "m=%s,x=%g" % (c[0], c[1]))
def test_mie_efficiencies_miev0(case):
    m_table, x, qext, qsca, gqsca, _ = case
    m = m_table.conjugate()  # the table writes n - ik; grainlight takes n + ik
    e, s, b, g = grainlight.mie(m, x)
    assert isinstance(e, float) and isinstance(g, float)
    assert e == pytest.approx(qext, rel=2e-6)
    assert s == pytest.approx(qsca, rel=2e-6)
    assert g * s == pytest.approx(gqsca, rel=2e-6)


@pytest.mark.parametrize("case", CASES, ids=lambda c: "m=%s,x=%g" % (c[0], c[1]))
def test_mie_amplitudes_miev0(case):
    m_table, x, _, _, _, rows = case
    angles = sorted(rows)
    mu = np.cos(np.radians(angles))
    s1, s2 = grainlight.mie_S1_S2(m_table.conjugate(), x, mu)
    assert s1.dtype == np.complex128 and s1.shape == mu.shape
    for i, a in enumerate(angles):
        r1, r2 = rows[a]
        # 7 significant digits per component in the table.
        for ours, ref in ((s1[i], r1), (s2[i], r2)):
            assert ours.real == pytest.approx(ref.real, rel=2e-6, abs=1e-12), (a, ours, ref)
            assert ours.imag == pytest.approx(ref.imag, rel=2e-6, abs=1e-12), (a, ours, ref)


def test_miev0_self_test_140_degrees():
    # MIEV0's built-in self-test: m = 1.5 - 0.1i (table convention), x = 10.
    e, s, _, g = grainlight.mie(1.5 + 0.1j, 10.0)
    assert e == pytest.approx(2.459791, rel=2e-6)
    assert s == pytest.approx(1.235144, rel=2e-6)
    assert g * s == pytest.approx(1.139235, rel=2e-6)
    s1, s2 = grainlight.mie_S1_S2(1.5 + 0.1j, 10.0, math.cos(math.radians(140)))
    assert isinstance(s1, complex)
    assert s1 == pytest.approx(complex(-0.1548380, -1.128972), rel=3e-6)
    assert s2 == pytest.approx(complex(0.05669755, 0.5425681), rel=3e-6)
    s0, _ = grainlight.mie_S1_S2(1.5 + 0.1j, 10.0, 1.0)
    assert s0 == pytest.approx(complex(61.49476, -3.177994), rel=2e-6)


def test_bohren_huffman_appendix_a():
    x = 2 * math.pi * 0.525 / 0.6328
    e, s, b, g = grainlight.mie(1.55, x)
    assert e == pytest.approx(3.10543, abs=6e-5)
    assert s == pytest.approx(3.10543, abs=6e-5)
    assert b == pytest.approx(2.92534, abs=6e-5)
    assert g == pytest.approx(0.63314, abs=6e-6)


def test_array_x_keeps_shape_and_matches_scalars():
    x = np.array([[0.1, 1.0, 10.0], [50.0, 100.0, 1000.0]])
    out = grainlight.mie(1.33 + 0.01j, x)
    assert len(out) == 4
    for a in out:
        assert isinstance(a, np.ndarray) and a.shape == x.shape
    for idx in np.ndindex(x.shape):
        scalar = grainlight.mie(1.33 + 0.01j, float(x[idx]))
        for k in range(4):
            assert out[k][idx] == scalar[k]
    lst = grainlight.mie(1.5, [1.0, 2.0])  # lists are arrays too
    assert lst[0].shape == (2,)


def test_phase_function_from_amplitudes_is_normalized_and_has_mean_cosine_g():
    # Two routes must agree: g from the series (B&H Eq. 4.74) and the mean cosine of
    # (|S1|^2 + |S2|^2) / (2 pi x^2 Qsca) integrated over the sphere by Gauss-Legendre.
    m, x = 1.33 + 0.001j, 8.0
    _, qsca, _, g = grainlight.mie(m, x)
    mu, w = np.polynomial.legendre.leggauss(200)
    s1, s2 = grainlight.mie_S1_S2(m, x, mu)
    p = (np.abs(s1) ** 2 + np.abs(s2) ** 2) / (2 * math.pi * x * x * qsca)
    assert 2 * math.pi * np.sum(w * p) == pytest.approx(1.0, rel=1e-10)
    assert 2 * math.pi * np.sum(w * p * mu) == pytest.approx(g, rel=1e-9)


def test_optical_theorem_and_backscatter():
    # Re S(0) = x^2 Qext / 4 and Qback = 4 |S1(180)|^2 / x^2 (van de Hulst normalization).
    m, x = 1.5 + 0.02j, 25.0
    e, _, b, _ = grainlight.mie(m, x)
    s0, _ = grainlight.mie_S1_S2(m, x, 1.0)
    s180, _ = grainlight.mie_S1_S2(m, x, -1.0)
    assert s0.real == pytest.approx(x * x * e / 4, rel=1e-10)
    assert b == pytest.approx(4 * abs(s180) ** 2 / (x * x), rel=1e-10)


def test_large_x_is_finite():
    # Validated range goes to x = 1e5; extinction paradox: Qext -> 2.
    e, s, b, g = grainlight.mie(1.33, 1e5)
    assert all(math.isfinite(v) for v in (e, s, b, g))
    assert e == pytest.approx(2.0, abs=2e-3)


def test_negative_imaginary_part_is_rejected_naming_the_convention():
    for fn in (lambda: grainlight.mie(1.5 - 0.1j, 1.0), lambda: grainlight.mie_S1_S2(1.5 - 0.1j, 1.0, [0.0]),
               lambda: grainlight.goa(1.5 - 0.1j, 100.0), lambda: grainlight.goa_S1_S2(1.5 - 0.1j, 100.0, 0.5)):
        with pytest.raises(ValueError, match=r"n \+ i k with k >= 0.*miepython"):
            fn()


def test_bad_arguments_name_the_parameter():
    with pytest.raises(ValueError, match="x"):
        grainlight.mie(1.5, -1.0)
    with pytest.raises(ValueError, match="mu"):
        grainlight.mie_S1_S2(1.5, 1.0, [0.0, 1.5])
    with pytest.raises(ValueError, match="fraction"):
        grainlight.md_pack(100, 0.7)


def test_docstrings_state_the_convention():
    for name in ("mie", "mie_S1_S2", "goa", "goa_S1_S2", "bulk_optics"):
        assert "n + i k with k >= 0" in getattr(grainlight, name).__doc__, name
    assert "n + i k with k >= 0" in grainlight.__doc__


def test_goa_approaches_mie_for_large_spheres():
    # Guo21 Fig. 3: GOA extinction agrees with Mie for r >> lambda. GOA has no edge (glory /
    # surface-wave) term, which van de Hulst puts at ~2 x^(-2/3) in Qext: 0.6 % at x = 2000.
    m, x = 1.33 + 1e-4j, 2000.0
    qm = grainlight.mie(m, x)
    qg = grainlight.goa(m, x)
    assert qg[0] == pytest.approx(qm[0], rel=1e-2)
    assert qm[0] - qg[0] == pytest.approx(2 * x ** (-2 / 3), rel=0.5)
    assert qg[1] == pytest.approx(qm[1], rel=2e-2)
    arr = grainlight.goa(m, np.array([500.0, 2000.0]))
    assert arr[0].shape == (2,) and arr[0][1] == qg[0]
    # Side-scattering amplitudes of GOA and Mie have the same magnitude scale at 60 degrees.
    s1g, _ = grainlight.goa_S1_S2(m, x, 0.5)
    s1m, _ = grainlight.mie_S1_S2(m, x, 0.5)
    assert 0.1 < abs(s1g) / abs(s1m) < 10


def test_lognormal_pdf_integrates_to_its_cdf():
    r = np.linspace(0.5, 40.0, 20001)
    pdf, cdf = grainlight.lognormal_pdf(r, 5.0, 1.6, 0.5, 40.0)
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (pdf[1:] + pdf[:-1]) * np.diff(r))])
    assert np.max(np.abs(integral - cdf)) < 1e-6
    assert cdf[-1] == pytest.approx(1.0, abs=1e-12)


def test_bulk_optics_of_a_narrow_distribution_matches_one_particle():
    # sigma_g -> 1: sigma_t = N0 C_t(r_g) 1e-12 [1/m] with C_t = Qext pi r^2 (Guo21 Eq. 16).
    lam, r, n0 = 0.55, 1.0, 1e12
    b = grainlight.bulk_optics(1.33 + 0.0j, [lam], r_g=r, sigma_g=1.001, r_min=0.99, r_max=1.01,
                               number_density=n0, method="mie")
    qext, qsca, _, g = grainlight.mie(1.33, 2 * math.pi * r / lam)
    assert b["sigma_t"][0] == pytest.approx(n0 * qext * math.pi * r * r * 1e-12, rel=5e-3)
    assert b["sigma_s"][0] == pytest.approx(b["sigma_t"][0], rel=1e-9)
    assert b["g"][0] == pytest.approx(g, rel=5e-3)
    mu = np.cos(b["theta"])
    integral = 2 * math.pi * np.trapz(b["phase"][0][::-1], mu[::-1])
    assert integral == pytest.approx(1.0, rel=1e-2)
    with pytest.raises(ValueError, match="method"):
        grainlight.bulk_optics(1.33, [lam], r_g=r, sigma_g=1.5, method="rayleigh")


def test_md_pack_tile_centres():
    d = grainlight.md_pack(200, 0.55, seed=3, side=2.0)
    c, R, L = d["centres"], d["radius"], d["side"]
    assert c.shape == (200, 3) and L == 2.0
    assert np.all(c >= 0) and np.all(c < L)
    assert d["fraction"] == pytest.approx(200 * 4 / 3 * math.pi * R ** 3 / L ** 3, rel=1e-12)
    assert d["fraction"] == pytest.approx(0.55, rel=1e-6) and d["reached_target"]
    diff = c[:, None, :] - c[None, :, :]
    diff -= L * np.round(diff / L)  # minimum image
    dist = np.sqrt((diff ** 2).sum(-1)) + np.eye(200) * 10 * L
    assert dist.min() >= 2 * R * (1 - 1e-9)
    again = grainlight.md_pack(200, 0.55, seed=3, side=2.0)
    assert np.array_equal(again["centres"], c)  # deterministic for a seed


def test_grain_stats_glass_bead_against_meng15_table1():
    # Meng15 Table 1, glass beads: beta 1.00, lambda_delta 0.00, alpha_s 1.00, lambda_s 1.44
    # (our bead: ior ~1.5 vs the paper's ~1.46; measured 1.43).
    assert "glass-bead" in grainlight.grain_presets()
    s = grainlight.grain_stats("glass-bead", rays=20000, seed=2)
    t = s["meng15_table1"]
    assert t["column"] == "glass beads" and t["lambda_s"] == 1.44
    assert s["beta"] == pytest.approx(1.0, abs=1e-12)
    assert s["lambda_delta"] == pytest.approx(0.0, abs=1e-12)
    assert np.allclose(s["alpha_s"], 1.0, atol=1e-3)  # lossless: only bounce-limit paths are lost
    assert np.mean(s["lambda_s"]) == pytest.approx(t["lambda_s"], abs=0.04)
    # The phase histogram holds every exiting ray: its sum is P(hit and exit) per channel.
    assert s["phase_hist"].shape == (3, len(s["mu_edges"]) - 1)
    assert np.allclose(s["phase_hist"].sum(axis=1), s["exit_probability"], rtol=1e-12)
    again = grainlight.grain_stats("glass-bead", rays=20000, seed=2)
    assert np.array_equal(again["phase_hist"], s["phase_hist"])
    with pytest.raises(ValueError, match="preset"):
        grainlight.grain_stats("granite")
