"""Eq. (1) of the paper, branch by branch."""

import numpy as np
import pytest

from ur5fault.sim.drive.gearbox import gear_torque

K, C, A = 1.0e5, 20.0, 1.0e-3


def test_no_backlash_is_spring_damper_everywhere_including_pull():
    th = np.linspace(-1e-3, 1e-3, 41)
    for dth in (-0.5, 0.0, 0.7):
        np.testing.assert_array_equal(gear_torque(th, dth, K, C, 0.0), K * th + C * dth)
    # with alpha = 0 there is no push-only clamp: a pulling torque is transmitted
    assert gear_torque(1e-4, -10.0, K, C, 0.0) == pytest.approx(K * 1e-4 - C * 10.0) and K * 1e-4 - C * 10 < 0


def test_contact_on_alpha_flank_pushes():
    th, dth = A + 2e-4, 0.1
    assert gear_torque(th, dth, K, C, A) == pytest.approx(K * (th - A) + C * dth)
    assert gear_torque(th, dth, K, C, A) > 0


def test_alpha_flank_cannot_pull():
    th, dth = A + 1e-5, -1.0  # k*(th-a) + c*dth = 1 - 20 < 0
    assert K * (th - A) + C * dth < 0
    assert gear_torque(th, dth, K, C, A) == 0.0


def test_contact_on_zero_flank_pushes_negative():
    th, dth = -3e-4, -0.2
    assert gear_torque(th, dth, K, C, A) == pytest.approx(K * th + C * dth)
    assert gear_torque(th, dth, K, C, A) < 0


def test_zero_flank_cannot_pull():
    th, dth = -1e-5, 2.0  # k*th + c*dth = -1 + 40 > 0
    assert gear_torque(th, dth, K, C, A) == 0.0


@pytest.mark.parametrize("th", [0.0, 1e-4, 5e-4, A])
@pytest.mark.parametrize("dth", [-3.0, 0.0, 3.0])
def test_inside_the_clearance_no_torque(th, dth):
    assert gear_torque(th, dth, K, C, A) == 0.0


def test_vectorised_over_batch_and_joints_with_mixed_alpha():
    th = np.array([[2e-3, -1e-3], [5e-4, 5e-4]])
    alpha = np.array([[A, A], [0.0, A]])
    out = gear_torque(th, 0.0, K, C, alpha)
    np.testing.assert_allclose(out, [[K * (2e-3 - A), K * -1e-3], [K * 5e-4, 0.0]])
    assert out.shape == (2, 2)


def test_torque_continuous_at_contact():
    eps = 1e-12
    assert abs(gear_torque(A + eps, 0.0, K, C, A)) < 1e-6
    assert abs(gear_torque(-eps, 0.0, K, C, A)) < 1e-6
