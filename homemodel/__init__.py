"""homemodel: offline 3D modelling and reconstruction of a home for a service robot.

The command line lives in `homemodel.cli`; shared helpers (errors, atomic writes,
transforms, safe XML) live beside it. See README.md for the tour.
"""

__version__ = "0.1.0"
