"""Homogeneous fog (OpenGL GL_EXP): rho constant, tau = rho d."""

from __future__ import annotations

import numpy as np


def density(layer, x, t, wind):
    return np.full(len(x), layer.density)


def optical_depth(layer, O, omega, d, t, wind):
    return layer.density * d
