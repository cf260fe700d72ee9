"""USERSIG FRESFVA of fis_rig_cat_s_3d.dat: the channel wall's contact loads on the rigid
catheter's position nodes 1, 5, ..., 45 (orientation nodes 2, 6, ..., 46); fis_channel.py
has the model. Run: spacarpy run fis_rig_cat_s_3d.dat --mode transient --allow-user-code
--user-module decks/user-routines/fis"""
import numpy as np
from fis_channel import V_REAL, V_SIM, contact_rows

NODES = np.arange(1, 46, 4)


def FRESFVA(t, state):  # noqa: N802 (the deck's name)
    return contact_rows(state, NODES, 4, V_SIM / V_REAL)
