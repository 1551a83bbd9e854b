"""A scene's system pickles (as its scene, settings and plain fields; the kernel as its scene),
so that results holding it -- periodic orbits, branches, a study's route to chaos -- cross
processes (nld.study.background runs the excavator's route on a process of its own)."""
import pickle

import numpy as np

from nld.systems.base import integrate
from nld.systems.core import SceneSystem
from nld.sweeps.executors import Background


def one_revolution(system):
    T = system.period
    sol = integrate(system, 0.0, system.y0, system.z0, np.array([T]), land=True, rtol=1e-8,
                    max_steps=200_000)
    assert sol.status == 0
    return sol.Y[-1]


def changed_system():
    s = SceneSystem("slider_crank", ["joints.B.clearance=2e-4"])
    s.y0 = s.y0 + 1e-6 * s.scales      # a start state of its own, kept through pickling
    return s


def test_a_pickled_scene_system_keeps_its_state_parameters_and_motion():
    s = changed_system()
    t = pickle.loads(pickle.dumps(s))
    assert t.scene.joints["B"].clearance == 2e-4
    np.testing.assert_array_equal(t.y0, s.y0)
    np.testing.assert_array_equal(t.p, s.p)
    np.testing.assert_array_equal(t.scales, s.scales)
    np.testing.assert_array_equal(one_revolution(t), one_revolution(s))


def test_a_scene_system_integrates_the_same_in_another_process():
    s = changed_system()
    with Background(one_revolution, s) as job:
        there = job.result()
    np.testing.assert_array_equal(there, one_revolution(s))
