"""USERSIG FFESFVA of fis_flex_cat_s_3d.dat: the channel wall's contact loads on the flexible
catheter's position nodes 1, 3, ..., 47 (orientation nodes 2, 4, ..., 48); the insertion
runs twice as fast as the rigid deck's, so the velocities are scaled by 40; fis_channel.py
has the model."""
import numpy as np
from fis_channel import V_REAL, V_SIM, contact_rows

NODES = np.arange(1, 48, 2)


def FFESFVA(t, state):  # noqa: N802 (the deck's name)
    return contact_rows(state, NODES, 2, 2 * V_SIM / V_REAL)
