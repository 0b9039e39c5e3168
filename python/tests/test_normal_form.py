import numpy as np
import pytest

import lasalle

MU = 0.01215058560962404  # Earth–Moon


def test_l4_frequencies_and_d4_against_the_closed_forms():
    nf = lasalle.normal_form("cr3bp", order=6, params={"mu": MU})
    # ω² = (1 ± √(1 − 27μ(1−μ)))/2 at L4
    s = np.sqrt(1 - 27 * MU * (1 - MU))
    omega = sorted(o["value"] for o in nf["omega"])
    np.testing.assert_allclose(omega, np.sqrt([(1 - s) / 2, (1 + s) / 2]), rtol=1e-13)
    # Deprit & Deprit-Bartholomé's D₄ (sign as derived in the normal-form crate's docs)
    w = 27 * MU * (1 - MU) / 4
    d4 = (36 - 541 * w + 644 * w**2) / (8 * (1 - 4 * w) * (4 - 25 * w))
    assert nf["d4"]["d4"]["value"] == pytest.approx(d4, rel=1e-10)
    assert nf["precision"] == "dd"
    assert isinstance(nf["linear_map"], np.ndarray) and nf["linear_map"].shape == (4, 4)


def test_the_models_own_parameters_are_used():
    m = lasalle.Model("cr3bp")
    m.params["mu"] = MU
    a = lasalle.normal_form(m, order=4, precision="f64")
    b = lasalle.normal_form("cr3bp", order=4, precision="f64", params={"mu": MU})
    assert a["d4"]["d4"]["value"] == b["d4"]["d4"]["value"]


def test_bad_arguments():
    with pytest.raises(ValueError, match="order"):
        lasalle.normal_form("cr3bp", order=1)
    for order in (-1, 0, 2.5, 10**30 + 0.5, "twelve"):
        with pytest.raises(ValueError, match="order must be a whole number ≥ 1"):
            lasalle.normal_form("cr3bp", order=order)
    with pytest.raises(ValueError, match="resonance_tol"):
        lasalle.normal_form("cr3bp", resonance_tol=-1.0)
    with pytest.raises(ValueError, match="precision"):
        lasalle.normal_form("cr3bp", precision="quad")
    with pytest.raises(ValueError, match="unknown parameter"):
        lasalle.normal_form("cr3bp", params={"nu": 0.1})
    # past Routh's mass ratio L4 is not elliptic
    with pytest.raises(ValueError, match="ellip"):
        lasalle.normal_form("cr3bp", order=4, params={"mu": 0.1})
