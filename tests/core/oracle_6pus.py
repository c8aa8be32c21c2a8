"""The 6-PUS the core serves from robots/6pus.toml against the hand-written 6-PUS kept as a
test oracle (c_core/tests/oracles/, robot "6pus_hand" of libpkm_oracle.so).

Run by tests/core/test_described.py with PKM_LIB pointing at libpkm_oracle.so (the library
the C++ tests link): the hand-written model exists in no library the package ships.  Exits
non-zero with the failed assertion."""
import numpy as np

from cosim.core import Model

from described_checks import rel, samples


def same_parameter_table(a, b):
    ia, ib = a.param_info(), b.param_info()
    assert [p.name for p in ia] == [p.name for p in ib]
    assert [p.unit for p in ia] == [p.unit for p in ib]
    assert a.params() == b.params()
    assert a.facts.pose_names == b.facts.pose_names and a.joint_unit == b.joint_unit


def same_model(a, b):
    X, XD, XDD = samples(a, 1000, seed=7)
    assert rel(a.ik(X), b.ik(X)) < 1e-10
    assert rel(a.inverse_dynamics(X, XD, XDD), b.inverse_dynamics(X, XD, XDD)) < 1e-10
    T = a.inverse_dynamics(X, XD, XDD)
    assert rel(a.forward_dynamics(X, XD, T), b.forward_dynamics(X, XD, T)) < 1e-10
    for x, xd, xdd in zip(X[::10], XD[::10], XDD[::10]):  # the per-pose functions at 100 of them
        for fa, fb in zip(a.jacobians(x), b.jacobians(x)):
            assert rel(fa, fb) < 1e-10
        assert rel(a.jacobian_dot(x, xd), b.jacobian_dot(x, xd)) < 1e-10
        assert rel(a.mass_matrix(x), b.mass_matrix(x)) < 1e-10
        assert rel(a.joint_acceleration(x, xd, xdd), b.joint_acceleration(x, xd, xdd)) < 1e-10
        assert rel(np.array(a.energy(x, xd)), np.array(b.energy(x, xd))) < 1e-10
        assert rel(a.singularity(x), b.singularity(x)) < 1e-10
    x = a.home() + np.array([0.004, -0.003, 0.002, 0.02, -0.01, 0.03])
    np.testing.assert_allclose(a.chain_points(x), b.chain_points(x), rtol=0, atol=1e-15)


if __name__ == "__main__":
    hand, served = Model("6pus_hand"), Model("6pus")
    same_parameter_table(hand, served)
    same_model(hand, served)
    print("ok")
