"""What the renderer is measured against, kept apart from what it renders with: the numpy reference
of the depth-image intersection (reference.py), the same GLSL run on arrays of rays (ray_query.py),
the Embree-traced truth (truth.py) and the figures of a frame against it (compare.py)."""
