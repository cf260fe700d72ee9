"""``python -m spacarpy``: the same entry point as the ``spacarpy`` console script."""
from spacarpy.cli import console

if __name__ == "__main__":      # (importing it, as the API reference does, runs nothing)
    console()
