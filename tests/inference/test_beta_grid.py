"""The beta-grid shortcut (one exp, then squaring for each doubled beta) equals a direct
Boltzmann computation (planning.policy.BoltzmannPolicy) for every beta of the grid."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import siftom.world.domains.kitchen  # noqa: F401
from siftom.inference.model import ModelConfig, SIFToM
from siftom.planning.policy import BoltzmannPolicy
from siftom.scenarios.base import get_scenario


def _online(betas):
    sc = get_scenario("kitchen-cereal-v0")
    return SIFToM(ModelConfig(mode="action-only", betas=betas)).online(sc.world, sc.start, sc.goals, sc.verb)


q_tables = st.integers(2, 7).flatmap(lambda a: st.integers(1, 5).flatmap(
    lambda r: arrays(np.float64, (a, r), elements=st.floats(0, 40, allow_nan=False))))


@settings(max_examples=60, deadline=None)
@given(Q=q_tables, data=st.data(),
       betas=st.sampled_from([(0.5, 1.0, 2.0, 4.0), (0.25, 0.5, 1.0), (0.5, 1.5, 3.0, 7.0), (2.0,)]))
def test_grid_log_likelihood_equals_direct_boltzmann(Q, data, betas):
    k = data.draw(st.integers(0, Q.shape[0] - 1))
    online = _online(betas)
    got = online.actions.step_log_lik(Q, k)  # (R, B)
    eps = online.model.config.epsilon
    for b, beta in enumerate(betas):
        want = BoltzmannPolicy(beta=beta, epsilon=eps).log_probs(Q)[k]
        np.testing.assert_allclose(got[:, b], want, rtol=1e-9, atol=1e-9)


def test_large_costs_do_not_underflow_the_squared_grid():
    Q = np.array([[0.0, 300.0], [200.0, 0.0], [1e9, 1e9]])
    online = _online((0.5, 1.0, 2.0, 4.0))
    got = online.actions.step_log_lik(Q, 0)
    assert np.all(np.isfinite(got))
    for b, beta in enumerate((0.5, 1.0, 2.0, 4.0)):
        want = BoltzmannPolicy(beta=beta, epsilon=online.model.config.epsilon).log_probs(Q)[0]
        np.testing.assert_allclose(got[:, b], want, rtol=1e-9, atol=1e-9)
