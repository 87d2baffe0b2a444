"""Drawing the scene: orbit camera, normal-mapped shading, shadows, debug views."""
