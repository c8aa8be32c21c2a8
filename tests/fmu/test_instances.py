"""Several instances at once share nothing: interleaved runs equal separate runs."""
import numpy as np

from cosim import fmu

H = 1e-3


def test_interleaved_instances_are_independent(fmu_file, hold):
    light = {"platform.m": 0.30}
    heavy = {"platform.m": 0.45, "leg[2].L": 0.117}
    alone = []
    for p in (light, heavy):
        with fmu.FMUInstance(fmu_file, params=p) as f:
            for _ in range(30):
                f.step(H, tau=hold)
            alone.append(f.vector("x"))
    a = fmu.FMUInstance(fmu_file, name="a", params=light)
    b = fmu.FMUInstance(fmu_file, name="b", params=heavy)
    c = fmu.FMUInstance(fmu_file, name="c", kind="ModelExchange")  # a third, of the other kind
    for _ in range(30):
        a.step(H, tau=hold)
        b.step(H, tau=-hold)  # b is pushed elsewhere between a's steps...
        c.set_vector("tau", 0 * hold)
        c.derivatives()
    b.close()
    b = fmu.FMUInstance(fmu_file, name="b2", params=heavy)
    for _ in range(30):
        b.step(H, tau=hold)
    assert np.array_equal(a.vector("x"), alone[0])  # ... and a never noticed
    assert np.array_equal(b.vector("x"), alone[1])
    assert not np.array_equal(alone[0], alone[1])
    for f in (a, b, c):
        f.close()
