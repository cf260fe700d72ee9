"""USERINP FRESMVA of fis_rig_cat_s_3d.dat: node 49 pushed along x at 0.1 m/s until the
insertion depth 0.12 m is reached (t = 1.2 s); fis_channel.py has the model."""
from fis_channel import DEPTH, V_SIM, insertion


def FRESMVA(t):  # noqa: N802 (the deck's name)
    return insertion(t, 49, DEPTH / V_SIM, V_SIM)
