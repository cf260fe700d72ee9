"""``python -m spacarpy``: the same entry point as the ``spacarpy`` console script."""
from spacarpy.cli import console

console()
