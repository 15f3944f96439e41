"""Float64 numpy references of every fog layer kind.

Each module holds one kind: its density (where it has one) and its closed form along a
ray O -> O + omega d. Arrays are vectorised over rays: O and omega (N, 3), d and t (N,).
`transmittance.py` composes them exactly as render/shaders/fog/transmittance.glsl does.
"""
