"""Peer codes that solve the ``spacarpy bench`` problems, for side-by-side comparison."""
