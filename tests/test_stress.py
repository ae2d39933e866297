"""Longitudinal p-atic stress of MPF cells against the exact integral of a tanh-profile ellipse."""
import numpy as np
import pytest

from hexatissue import InputError

from math import factorial  # noqa: E402

from scipy.integrate import quad  # noqa: E402

from hexatissue.simulate.stress import cell_stress  # noqa: E402


def tanh_ellipse(a, b, eps, size, angle=0.0, shift=(0.0, 0.0)):
    """phi = (1 - tanh((rho - 1) / eps)) / 2 with rho^2 = u^2/a^2 + v^2/b^2, (u, v) the frame rotated by angle."""
    y, x = np.mgrid[0:size, 0:size].astype(float) - (size - 1) / 2
    x, y = x - shift[0], y - shift[1]
    u = np.cos(angle) * x + np.sin(angle) * y
    v = -np.sin(angle) * x + np.cos(angle) * y
    return 0.5 * (1 - np.tanh((np.sqrt((u / a) ** 2 + (v / b) ** 2) - 1) / eps))


def exact_stress(a, b, eps, p, k_phi=1.0):
    """Continuum sigma_par of tanh_ellipse for theta = 0 (exact up to terms ~exp(-4/eps)).

    With x = a rho cos t, y = b rho sin t: phi_x + i phi_y = f'(rho) (cos t / a + i sin t / b),
    dA = a b rho drho dt, and int f'^p rho drho = (2 eps)^-p eps int sech^{2p} = (2 eps)^-p eps 2^{2p-1} ((p-1)!)^2/(2p-1)!
    (the odd part of rho = 1 + eps u integrates to zero).
    """
    radial = (2 * eps) ** -p * eps * 2 ** (2 * p - 1) * factorial(p - 1) ** 2 / factorial(2 * p - 1)
    angular = quad(lambda t: np.real((np.cos(t) / a + 1j * np.sin(t) / b) ** p), 0, 2 * np.pi, limit=200)[0]
    return -k_phi * a * b * radial * angular  # f'^p > 0 for even p


@pytest.mark.parametrize("p, size, tol", [(2, 121, 0.015), (6, 241, 0.03)])
def test_stress_of_a_tanh_ellipse_matches_the_continuum_integral(p, size, tol):
    scale = (size - 1) / 120  # a = 28 scale, b = 18 scale: interfaces 5-8 scale px wide
    a, b = 28 * scale, 18 * scale
    phi = tanh_ellipse(a, b, 0.3, size)[None]
    sigma = cell_stress(phi, np.zeros(1), k_phi=2.0, p=p)[0]
    exact = exact_stress(a, b, 0.3, p, k_phi=2.0)
    assert sigma == pytest.approx(exact, rel=tol)
    if p == 2:
        # elongated along theta = 0: positive along the long axis, as sign(1/a^2 - 1/b^2) * (-1) says
        assert sigma > 0 and exact == pytest.approx(2.0 * np.pi * a * b * (1 / b**2 - 1 / a**2) / (3 * 0.3))


def test_stress_discretisation_error_is_second_order():
    errors = []
    for scale, size in ((1, 121), (2, 241)):
        phi = tanh_ellipse(28 * scale, 18 * scale, 0.3, size)[None]
        sigma = cell_stress(phi, np.zeros(1), 1.0, 6)[0]
        errors.append(abs(sigma / exact_stress(28 * scale, 18 * scale, 0.3, 6) - 1))
    assert errors[0] / errors[1] > 3.5  # halving the lattice spacing divides the error by ~4


@pytest.mark.parametrize("p, tol", [(2, 0.01), (6, 0.07)])
def test_stress_angular_dependence_and_rotation(p, tol):
    base = tanh_ellipse(32, 20, 0.3, 161)
    theta = np.linspace(0, np.pi, 7)
    sigma = cell_stress(np.repeat(base[None], len(theta), axis=0), theta, 1.0, p)
    # mirror symmetry kills the sin(p theta) part: sigma(theta) = sigma(0) cos(p theta)
    np.testing.assert_allclose(sigma, sigma[0] * np.cos(p * theta), atol=1e-9 * abs(sigma[0]))
    # a cell rotated by beta, measured along beta, gives the same stress up to the lattice
    # anisotropy of the finite differences (second order: 0.5 % for p = 2, 6 % for p = 6 here)
    beta = np.deg2rad(30)
    rotated = cell_stress(tanh_ellipse(32, 20, 0.3, 161, angle=beta)[None], np.array([beta]), 1.0, p)[0]
    assert rotated == pytest.approx(sigma[0], rel=tol)
    # a translated cell gives the same stress
    moved = cell_stress(tanh_ellipse(32, 20, 0.3, 161, shift=(3.4, -2.2))[None], np.zeros(1), 1.0, p)[0]
    assert moved == pytest.approx(sigma[0], rel=1e-3)


@pytest.mark.parametrize("p", [2, 6])
def test_stress_of_a_round_cell_vanishes(p):
    # a disk centred on the lattice is symmetric under 90-degree rotations, which flip the sign of z^p
    disk = tanh_ellipse(12, 12, 0.2, 51)
    gy, gx = np.gradient(disk)
    scale = (np.hypot(gx, gy) ** p).sum()
    assert abs(cell_stress(disk[None], np.array([0.4]), 1.0, p)[0]) < 1e-12 * scale


def test_stress_bad_input():
    phi = np.zeros((2, 9, 9))
    with pytest.raises(InputError, match="phi"):
        cell_stress(np.zeros((9, 9)), np.zeros(1), 1.0, 2)
    with pytest.raises(InputError, match="theta"):
        cell_stress(phi, np.zeros(3), 1.0, 2)
    with pytest.raises(InputError, match="p must"):
        cell_stress(phi, np.zeros(2), 1.0, 0)
