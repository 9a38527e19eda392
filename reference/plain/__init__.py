"""The reference path: the model and its algorithms in plain NumPy, from the same generated physics."""
