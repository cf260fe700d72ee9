"""The version of spacarpy, in a module of its own so that the driver modules can name it
without importing the package root (which imports the driver lazily: no import cycle)."""
__version__ = "0.1.0"
