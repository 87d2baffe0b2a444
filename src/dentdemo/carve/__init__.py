"""The dent carve on the GPU (DESIGN.md "The carve"). Knows nothing of ODE: it takes poses, a
contact frame and a depth."""
