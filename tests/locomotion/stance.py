"""A standing robot heading +x, shared by the fit's and the teacher's tests.

Thighs (hip joints) 0.22 m up, knees 0.02 m ahead at 0.11 m, soles on the floor under the
thighs; rows FL, FR, HL, HR. ``test_fit.py`` uses the thighs as the hips too.
"""

import numpy as np

THIGH = np.array(
    [[0.15, 0.12, 0.22], [0.15, -0.12, 0.22], [-0.15, 0.12, 0.22], [-0.15, -0.12, 0.22]]
)
KNEE = THIGH + [0.02, 0.0, -0.11]
FOOT = THIGH + [0.0, 0.0, -0.20]
FOOT[:, 2] = 0.018
