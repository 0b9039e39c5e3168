import pathlib

import pytest

import lasalle

ROOT = pathlib.Path(__file__).resolve().parents[2]

# q'' = -w² q: q = cos(w t), p = -w sin(w t) from (1, 0); E = p²/2 + w² q²/2 = w²/2
OSCILLATOR = """model Osc {
    state q: scalar, p: scalar;
    param w = 2;
    d/dt q = p;
    d/dt p = -w^2 * q;
    integral E = p^2/2 + w^2 * q^2/2 gain 10;
    point start { q = 1; p = 0; }
}
"""


@pytest.fixture
def kepler():
    return lasalle.Model("kepler")


@pytest.fixture
def osc():
    return lasalle.Model.from_source(OSCILLATOR, path="osc.lsl")
