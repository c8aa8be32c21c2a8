"""Shared by the import tests: the map of the test rig (four-bar, one joint in rad, effort in N m)."""

MAP = '''robot = "fourbar"
notes = "a test rig"

[columns]
time = { variable = "zeit", unit = "ms" }
q1 = { variable = "ang", unit = "deg" }
qd1 = { derive = "central_difference" }
tau1 = { variable = "cmd", scale = { variable = "gain" }, unit = "N m" }
qref1 = { variable = "ref", unit = "deg" }
f_ext1 = { variable = "push", optional = true }

[sensors]
q1 = { resolution = 0.01, noise_std = 0.02 }

[controller]
kind = "discrete"
period = 0.002
kp = { variable = "k_p" }
filter = { b = [0.5, 0.5], a = [1.0] }
'''
