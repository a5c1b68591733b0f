import numpy as np
import pytest
from scipy.integrate import quad
from scipy.stats import norm

from track_core.idsq.models import (
    DEG,
    SimNoise,
    TrackerParams,
    acoustic_likelihood,
    bearings,
    doa_likelihood,
    doa_sigma,
    simulate_measurement,
)

P = TrackerParams()


@pytest.mark.parametrize(('z', 'r'), [(1.0, 30.0), (0.5, 100.0), (3.0, 10.0), (0.05, 60.0)])
def test_eq6_closed_form_matches_the_integral_over_amplitude(z, r):
    def integrand(a):
        return norm.pdf(z, loc=a / r, scale=P.sigma_a) / (P.a_hi - P.a_lo)

    ref, _ = quad(integrand, P.a_lo, P.a_hi, points=[r * z], limit=200)
    assert np.isclose(float(acoustic_likelihood(z, r, P)), ref, rtol=1e-6, atol=1e-12)


def test_eq6_is_a_density_in_z():
    z = np.linspace(-1, 10, 20001)
    for r in (10.0, 40.0, 120.0):
        assert np.isclose(np.trapezoid(acoustic_likelihood(z, r, P), z), 1.0, atol=1e-3)


def test_bearing_convention_is_from_north_clockwise():
    s = np.array([10.0, 10.0])
    pts = np.array([[10, 20], [20, 10], [10, 0], [0, 10], [20, 20]], float)
    np.testing.assert_allclose(bearings(pts, s), [0, np.pi / 2, np.pi, -np.pi / 2, np.pi / 4], atol=1e-12)


def test_doa_likelihood_wraps_across_pi():
    th, r = np.pi - 1 * DEG, 50.0
    z = -np.pi + 1 * DEG  # 2° away across the cut
    assert np.isclose(doa_likelihood(z, th, r, P), doa_likelihood(th + 2 * DEG, th, r, P))
    assert doa_likelihood(z, th, r, P) > 0.9 * doa_likelihood(th, th, r, P)


def test_fig6_sigma_flat_in_working_range_and_growing_outside():
    s = doa_sigma(np.array([0.0, 10.0, 20.0, 60.0, 100.0, 150.0, 1e4]), P)
    np.testing.assert_allclose(s[2:5], 10 * DEG)
    assert s[0] > s[1] > s[2] and s[5] > s[4]
    np.testing.assert_allclose(s[0], 10 * DEG + 20 * P.near_slope)
    np.testing.assert_allclose(s[5], 10 * DEG + 50 * P.far_slope)
    assert s[-1] == P.sigma_doa_max


def test_fig6_near_field_reaches_no_evidence_at_the_sensor():
    """The derived near slope (σ(0) = σ_max, models.py) follows σ₀, r_near and σ_max; a number overrides it."""
    assert np.isclose(P.near_slope, 4 * DEG)
    assert np.isclose(doa_sigma(0.0, P), P.sigma_doa_max) and np.isclose(doa_sigma(P.r_near, P), P.sigma_doa)
    q = TrackerParams(sigma_doa=5 * DEG, r_near=10.0, sigma_doa_max=45 * DEG)
    assert np.isclose(doa_sigma(0.0, q), 45 * DEG) and np.isclose(q.near_slope, 4 * DEG)
    assert TrackerParams(near_slope=1.5 * DEG).near_slope == 1.5 * DEG
    assert TrackerParams(r_near=0.0).near_slope == 0.0


def test_near_field_doa_leader_keeps_the_near_prior():
    """Issue 17, maritime seed 3, t = 28 s (prior 14 m off, DOA leader 1.5 m from the target, exact bearing):
    with σ(0) = σ_max the posterior keeps more mass near the sensor and ends nearer the target than with the
    former 1.5°/m near slope (σ(0) = 40°), which cut the near cells off the ray like far ones."""
    from track_core.idsq.grid import GridSpec, estimate, sparsify, uniform_belief
    from track_core.idsq.tracker import update

    g = GridSpec.for_field(150.0, 300.0, 5.0)
    u = uniform_belief(g)
    prior_mean, truth, sensor = np.array([107.0, 254.4]), np.array([97.2, 244.4]), np.array([96.0, 245.3])
    prior = sparsify(g, u.idx, np.exp(-0.5 * np.sum((u.centers() - prior_mean) ** 2, axis=1) / 11.0**2), P.sparsity)
    z = float(bearings(truth, sensor))
    out = {}
    for name, p in (('derived', P), ('1.5deg/m', TrackerParams(near_slope=1.5 * DEG))):
        post, ok = update(prior, z, sensor, True, p)
        assert ok
        near = np.hypot(*(post.centers() - sensor).T) < 10.0
        out[name] = (float(np.hypot(*(estimate(post).mean - truth))), float(post.mass[near].sum() / post.mass.sum()))
    assert out['derived'][0] < out['1.5deg/m'][0] - 0.5  # 12.5 vs 13.5 m
    assert out['derived'][1] > out['1.5deg/m'][1] + 0.01  # 0.231 vs 0.215


def test_simulated_measurements_have_the_paper_noise():
    rng = np.random.default_rng(0)
    n, noise = 4000, SimNoise()
    truth, s = np.array([75.0, 100.0]), np.array([75.0, 60.0])
    za = np.array([simulate_measurement(truth, s, False, noise, e) for e in rng.standard_normal(n)])
    zd = np.array([simulate_measurement(truth, s, True, noise, e) for e in rng.standard_normal(n)])
    tol = 4 / np.sqrt(n)  # 4 standard errors
    assert abs(za.mean() - 1.0) < tol * 0.05 and abs(za.std() / 0.05 - 1) < 4 / np.sqrt(2 * n)
    assert abs(zd.mean()) < tol * 3 * DEG and abs(zd.std() / (3 * DEG) - 1) < 4 / np.sqrt(2 * n)


@pytest.mark.parametrize(('kw', 'name'), [({'v_max': -1.0}, 'v_max'), ({'a_hi': 0.0}, 'a_lo'),
                                          ({'r_far': 10.0}, 'r_near'), ({'sparsity': 1.5}, 'sparsity')])
def test_bad_parameters_raise_one_line(kw, name):
    with pytest.raises(ValueError, match=name) as ei:
        TrackerParams(**kw)
    assert '\n' not in str(ei.value)


def test_loudest_source_and_vectorised_amplitude_readings_match_the_scalar_rule():
    from track_core.idsq.models import SimNoise, amplitude_reading, amplitude_readings, loudest_source

    rng = np.random.default_rng(2)
    sensors, sources, normals = rng.uniform(0, 250, (30, 2)), rng.uniform(0, 250, (3, 2)), rng.standard_normal(30)
    loud = loudest_source(sources, sensors)
    for k in range(30):
        nearest = sources[np.argmin(np.hypot(*(sources - sensors[k]).T))]
        np.testing.assert_array_equal(loud[k], nearest)
        np.testing.assert_array_equal(loudest_source(sources, sensors[k]), nearest)
    noise = SimNoise()
    expected = [amplitude_reading(loud[k], sensors[k], noise, float(normals[k])) for k in range(30)]
    np.testing.assert_array_equal(amplitude_readings(sources, sensors, noise, normals), expected)  # bit-identical
    np.testing.assert_array_equal(loudest_source(sources[0], sensors), np.tile(sources[0], (30, 1)))
