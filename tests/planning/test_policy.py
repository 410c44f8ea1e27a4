"""The Boltzmann policy: P(a | s) proportional to exp(-beta Q), an epsilon floor, validated options."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from siftom.planning.policy import BoltzmannPolicy

q_tables = arrays(np.float64, st.tuples(st.integers(1, 8), st.integers(1, 4)),
                  elements=st.floats(0, 1e9, allow_nan=False))


@given(Q=q_tables, beta=st.floats(0, 50), eps=st.one_of(st.just(0.0), st.floats(1e-12, 0.99)))
def test_log_probs_normalise_per_goal(Q, beta, eps):
    lp = BoltzmannPolicy(beta, eps).log_probs(Q)
    assert lp.shape == Q.shape
    np.testing.assert_allclose(np.exp(lp).sum(axis=0), 1.0, rtol=1e-6)


@given(Q=q_tables, beta=st.floats(0, 50), eps=st.floats(1e-6, 0.99))
def test_epsilon_keeps_every_action_possible(Q, beta, eps):
    p = np.exp(BoltzmannPolicy(beta, eps).log_probs(Q))
    assert (p >= eps / Q.shape[0] * (1 - 1e-9)).all()


def test_lower_cost_is_more_likely_and_matches_the_formula():
    Q = np.array([[3.0], [4.0], [6.0]])
    beta, eps = 1.5, 0.1
    p = np.exp(BoltzmannPolicy(beta, eps).log_probs(Q))[:, 0]
    soft = np.exp(-beta * Q[:, 0]) / np.exp(-beta * Q[:, 0]).sum()
    np.testing.assert_allclose(p, (1 - eps) * soft + eps / 3, rtol=1e-12)
    assert p[0] > p[1] > p[2]


def test_beta_zero_is_uniform():
    p = np.exp(BoltzmannPolicy(0.0, 0.0).log_probs(np.array([[1.0], [50.0]])))
    np.testing.assert_allclose(p[:, 0], [0.5, 0.5])


@pytest.mark.parametrize(("beta", "eps"), [(-1.0, 0.0), (float("inf"), 0.0), (float("nan"), 0.0),
                                           (1.0, 1.0), (1.0, -0.1)])
def test_invalid_options_are_refused(beta, eps):
    with pytest.raises(ValueError, match="beta|epsilon"):
        BoltzmannPolicy(beta, eps)
