"""sid.smooth against the reference smoother (60-digit mpmath, cross-checked with SciPy's
make_smoothing_spline) and against identities."""

import numpy as np
import pytest

import sid


def reference(data, name):
    path = data / name
    header = path.read_text().splitlines()[0]
    fields = dict(f.split("=") for f in header.lstrip("# ").split() if "=" in f)
    table = np.genfromtxt(path, delimiter=",", names=True, skip_header=1)
    return float(fields["lam"]), table


@pytest.mark.parametrize("name", ["uniform_n101.csv", "nonuniform_n64.csv"])
def test_matches_the_reference_spline_and_its_derivatives(data, name):
    lam, r = reference(data, name)
    s = sid.smooth(r["t"], r["y"], lam=lam, weights=1.0 / r["dy"] ** 2)
    assert s.lam == pytest.approx(lam, rel=1e-12)
    scale = np.abs(r["g"]).max()
    np.testing.assert_allclose(s(r["t"]), r["g"], rtol=0, atol=1e-9 * scale)
    np.testing.assert_allclose(s(r["t"], 1), r["dg"], rtol=0, atol=1e-8 * np.abs(r["dg"]).max())
    np.testing.assert_allclose(s(r["t"], 2), r["d2g"], rtol=0, atol=1e-7 * np.abs(r["d2g"]).max())


def test_interpolates_at_lam_zero_and_reproduces_a_line_at_any_lam():
    x = np.sort(np.random.default_rng(3).uniform(0.0, 10.0, 200))
    y = np.sin(x)
    np.testing.assert_allclose(sid.smooth(x, y, lam=0.0)(x), y, atol=1e-12)
    line = 2.0 - 0.5 * x
    for lam in (1e-6, 1.0, 1e6):
        s = sid.smooth(x, line, lam=lam)
        np.testing.assert_allclose(s(x), line, atol=1e-10)
        np.testing.assert_allclose(s(x, 1), -0.5, atol=1e-10)
        np.testing.assert_allclose(s(x, 2), 0.0, atol=1e-10)


def test_chooses_lam_at_the_minimum_of_scipys_gcv_curve(data):
    _, r = reference(data, "uniform_n101.csv")
    curve = np.genfromtxt(data / "gcv_reference.csv", delimiter=",", names=True, skip_header=1)
    best = int(np.argmin(curve["gcv"]))
    s = sid.smooth(r["t"], r["y"])  # GCV with equal weights, as the reference curve
    assert curve["lam"][best - 1] < s.lam < curve["lam"][best + 1]
    assert 0 < s.dof < len(r["t"])


def test_a_scalar_gives_a_scalar_and_an_array_its_shape():
    x = np.linspace(0.0, 1.0, 11)
    s = sid.smooth(x, x**2, lam=1e-3)
    assert isinstance(s(0.5), float)
    assert s(np.zeros((2, 3))).shape == (2, 3)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: sid.smooth([0, 1, 2, 3], [1, 2, 3]), "same length"),
        (lambda: sid.smooth([0, 1, 0.5, 3], [1, 2, 3, 4]), "must not decrease"),
        (lambda: sid.smooth([0, 1, 2, 3], [1, np.nan, 3, 4]), "not finite"),
        (lambda: sid.smooth([0, 1, 2, 3], [1, 2, 3, 4], lam=-1.0), "lam"),
        (lambda: sid.smooth([0, 1, 2, 3], [1, 2, 3, 4], weights=[1, 0, 1, 1]), "weights"),
        (lambda: sid.smooth([0, 1, 2, 3], [1, 2, 3, 4], smoothing="aic"), "smoothing"),
        (lambda: sid.smooth([0, 1, 2, 3], [1, 2, 3, 4], lam=1.0)(0.5, nu=3), "nu"),
    ],
)
def test_bad_input_raises_value_error_naming_it(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_merges_samples_at_one_x_and_smooths_near_duplicate_scattered_points():
    s = sid.smooth([0, 1, 1, 2, 3], [0, 1, 3, 4, 6], lam=0.0)
    np.testing.assert_array_equal(s.knots, [0, 1, 2, 3])
    assert s(1.0) == pytest.approx(2.0)  # through the mean of the tied samples
    # A million sorted uniform-random points (gaps down to about 1e-12): a curve, as csaps
    # and R's smooth.spline return, within the noise of the truth.
    rng = np.random.default_rng(0)
    x = np.sort(rng.uniform(0.0, 1.0, 1_000_000))
    y = np.sin(6 * x) + 0.1 * rng.standard_normal(x.size)
    s = sid.smooth(x, y, lam=1e-6)
    assert s.merge_tolerance <= 1e-6
    assert np.abs(s(x) - np.sin(6 * x)).max() < 0.03
    with pytest.raises(ValueError, match="must not decrease"):
        sid.smooth([0, 2, 1, 3], [1, 2, 3, 4], lam=1.0)


@pytest.mark.parametrize("lam", [1e-4, 1e-2, 1.0])
def test_equals_csaps_with_p_one_over_one_plus_lam(data, lam):
    # csaps minimises p sum w (y - f)^2 + (1 - p) integral f''^2: with p = 1 / (1 + lam) that
    # is sid's criterion times p (tests/data/gen_csaps_reference.py).
    ref = np.genfromtxt(data / "csaps_reference.csv", delimiter=",", names=True, skip_header=1)
    ref = ref[ref["lam"] == lam]
    _, r = reference(data, "nonuniform_n64.csv")
    s = sid.smooth(r["t"], r["y"], lam=lam, weights=1.0 / r["dy"] ** 2)
    for nu, column in enumerate(("g", "dg", "d2g")):
        scale = np.abs(ref[column]).max()
        np.testing.assert_allclose(s(ref["t"], nu), ref[column], rtol=0, atol=1e-8 * scale)
