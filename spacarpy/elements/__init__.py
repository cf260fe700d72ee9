"""Element kinds: pure array kernels, one class per kind, and the registry that lists them."""
