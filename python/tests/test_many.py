"""solve_many: each row bitwise its lone solve, across threads, lanes and executors."""

import concurrent.futures

import numpy as np
import pytest

import lasalle


def kepler_rows(b, seed=1):
    """B Kepler orbits: the paper's point with the speed scaled by 0.9 … 1.1."""
    rng = np.random.default_rng(seed)
    y = np.tile([1.0, 0, 0, 0, np.sqrt(1.8), 0], (b, 1))
    y[:, 4] *= rng.uniform(0.9, 1.1, b)
    return y


def assert_rows_equal_lone_solves(m, many, y0s, method, rows, params=None, **opts):
    for i in rows:
        p = {k: v[i] for k, v in (params or {}).items()}
        lone = m.solve(y0s[i], (0, 5), method, params=p, every=2**64 - 1, **opts)
        k = many.n_t[i]
        assert k == len(lone.t)
        assert np.array_equal(many.t[i, :k], lone.t)
        assert np.array_equal(many.y[i, :, :k], lone.y), (method, i)
        assert np.array_equal(many.invariants[i, :, :k], lone.invariants)
        assert np.array_equal(many.max_drift[i], lone.max_drift)
        assert many.success[i] == lone.success and many.nfev[i] == lone.nfev


@pytest.mark.parametrize(
    "method, opts",
    [("rk4", dict(dt=0.01)), ("feedback-rk4", dict(dt=0.01)), ("dopri5", dict(rtol=1e-9, atol=1e-9)), ("taylor", dict(rtol=1e-12))],
)
def test_every_row_is_bitwise_its_lone_solve(kepler, method, opts):
    y0s = kepler_rows(24)
    many = kepler.solve_many(y0s, (0, 5), method, threads=2, **opts)
    assert many.y.shape == (24, 6, 2) and many.max_drift.shape == (24, 2) and many.success.shape == (24,)
    assert many.success.all()
    assert_rows_equal_lone_solves(kepler, many, y0s, method, range(24), **opts)
    # threads and lanes change nothing
    one = kepler.solve_many(y0s, (0, 5), method, threads=1, lanes=1, **opts)
    assert np.array_equal(one.y, many.y) and np.array_equal(one.max_drift, many.max_drift)


def test_parameters_per_row(kepler):
    y0s = kepler_rows(12)
    mu = np.linspace(0.8, 1.2, 12)
    many = kepler.solve_many(y0s, (0, 5), "rk4", dt=0.01, params={"mu": mu})
    assert_rows_equal_lone_solves(kepler, many, y0s, "rk4", range(12), params={"mu": mu}, dt=0.01)
    # and they differ from the model's own μ = 1
    same = kepler.solve_many(y0s, (0, 5), "rk4", dt=0.01)
    assert not np.array_equal(same.y[0], many.y[0])
    assert kepler.params["mu"] == 1.0


def test_one_value_applies_to_every_row(kepler):
    y0s = kepler_rows(6)
    one = kepler.solve_many(y0s, (0, 5), "rk4", dt=0.01, params={"mu": 0.9})
    per_row = kepler.solve_many(y0s, (0, 5), "rk4", dt=0.01, params={"mu": np.full(6, 0.9)})
    assert np.array_equal(one.y, per_row.y)
    zero_d = kepler.solve_many(y0s, (0, 5), "rk4", dt=0.01, params={"mu": np.float64(0.9)})
    assert np.array_equal(one.y, zero_d.y)


def test_intermediate_samples_when_asked(osc):
    y0s = np.array([[1.0, 0.0], [0.5, 0.5]])
    many = osc.solve_many(y0s, (0, 1), "rk4", dt=0.01, every=10)
    assert many.t.shape == (2, 11) and many.y.shape == (2, 2, 11)
    lone = osc.solve(y0s[1], (0, 1), "rk4", dt=0.01, every=10)
    assert np.array_equal(many.y[1], lone.y)


def test_a_failed_row_fails_alone(kepler):
    y0s = kepler_rows(4)
    y0s[2] = [0, 0, 0, 0, 1, 0]  # at the centre: outside the `collision` guard
    many = kepler.solve_many(y0s, (0, 5), "rk4", dt=0.01)
    assert many.success.tolist() == [True, True, False, True]
    assert "collision" in many.message[2]


def test_bad_batches_are_value_errors(kepler):
    with pytest.raises(ValueError, match=r"\(B, 6\)"):
        kepler.solve_many(np.zeros((3, 5)), (0, 1), "rk4", dt=0.1)
    with pytest.raises(ValueError, match="3 rows"):
        kepler.solve_many(kepler_rows(3), (0, 1), "rk4", dt=0.1, params={"mu": [1.0, 2.0]})
    with pytest.raises(ValueError, match="unknown parameter"):
        kepler.solve_many(kepler_rows(3), (0, 1), "rk4", dt=0.1, params={"nu": [1.0, 2.0, 3.0]})
    with pytest.raises(ValueError, match="threads"):
        kepler.solve_many(kepler_rows(3), (0, 1), "rk4", dt=0.1, threads=0)
    with pytest.raises(ValueError, match="lanes must be a whole number"):
        kepler.solve_many(kepler_rows(3), (0, 1), "rk4", dt=0.1, lanes=1.5)
    with pytest.raises(ValueError, match="rtol= applies to adaptive methods"):
        kepler.solve_many(kepler_rows(3), (0, 1), "rk4", dt=0.1, rtol=1e-8)


def test_a_process_pool_gives_the_serial_bits(kepler):
    y0s = kepler_rows(40)
    mu = np.linspace(0.9, 1.1, 40)
    serial = kepler.solve_many(y0s, (0, 5), "feedback-rk4", dt=0.01, params={"mu": mu})
    with concurrent.futures.ProcessPoolExecutor(2) as pool:
        sharded = kepler.solve_many(y0s, (0, 5), "feedback-rk4", dt=0.01, params={"mu": mu}, executor=pool, shards=5)
    assert np.array_equal(serial.y, sharded.y) and np.array_equal(serial.max_drift, sharded.max_drift)
    assert serial.message == sharded.message


def test_a_dask_cluster_gives_the_serial_bits(kepler):
    distributed = pytest.importorskip("dask.distributed")
    y0s = kepler_rows(64)
    serial = kepler.solve_many(y0s, (0, 5), "dopri5", rtol=1e-9, atol=1e-9)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with distributed.Client(cluster) as client:
            sharded = kepler.solve_many(
                y0s, (0, 5), "dopri5", rtol=1e-9, atol=1e-9, executor=client.get_executor(), shards=4
            )
    assert np.array_equal(serial.y, sharded.y) and np.array_equal(serial.t, sharded.t)
    assert sharded.success.all()
