"""Physical constants shared by every module (SI)."""

P_ATM_PA = 101_325.0
"""Standard atmospheric pressure [Pa]; gauge pressures are converted with it (docs/model.md §1.2)."""

G_MPS2 = 9.81
"""Gravitational acceleration [m/s^2] (roll gradient: static roll per 1 g lateral acceleration)."""

DOF_NAMES = ("z_s", "phi", "theta", "z_u1", "z_u2", "z_u3", "z_u4")
"""7-DOF state order of the full car (paper Eq. 1): body heave, roll, pitch, wheels FL FR RL RR."""

WHEEL_NAMES = ("fl", "fr", "rl", "rr")
