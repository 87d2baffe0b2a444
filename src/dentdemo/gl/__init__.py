"""OpenGL plumbing: the one place that makes contexts, the shader loader, GPU reads."""
