"""USERINP FFESMVA of fis_flex_cat_s_3d.dat: node 49 pushed along x at 0.2 m/s until the
insertion depth 0.12 m is reached (t = 0.6 s); fis_channel.py has the model."""
from fis_channel import DEPTH, V_SIM, insertion


def FFESMVA(t):  # noqa: N802 (the deck's name)
    return insertion(t, 49, DEPTH / (2 * V_SIM), 2 * V_SIM)
