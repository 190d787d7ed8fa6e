"""The stance of a standing robot in its heading frame, shared by the AEF policy's tests.

Torso at the origin, x ahead, y left, z above the floor; rows FL, FR, HL, HR.
"""

import numpy as np

HIPS = np.array(
    [[0.19, 0.07, 0.30], [0.19, -0.07, 0.30], [-0.19, 0.07, 0.30], [-0.19, -0.07, 0.30]]
)
THIGHS = HIPS + [[0, 0.05, 0], [0, -0.05, 0], [0, 0.05, 0], [0, -0.05, 0]]
KNEES = THIGHS + [0.02, 0.0, -0.12]
FEET = THIGHS.copy()
FEET[:, 2] = 0.018
